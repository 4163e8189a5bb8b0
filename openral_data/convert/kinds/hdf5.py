"""What the HDF5 source kinds share: a file or a folder of files (`formats.hdf5`), split by file, each kind
taking the layouts of its family (an HDF5 file of no known layout is one line, whichever HDF5 kind looks first)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from openral_data.convert.kinds.arrays import ArrayKind
from openral_data.formats.episodic import ArraySource

if TYPE_CHECKING:
    from openral_data.formats.hdf5 import HDF5Source


def hdf5_of(path: Path, layouts: tuple[str, ...], files: list[Path] | None = None) -> HDF5Source | None:
    """`path` (only `files` of it) as an HDF5 source of one of `layouts`; None when it holds no HDF5 file or
    another layout."""
    from openral_data.formats.hdf5 import detect_hdf5  # h5py only when a source is looked at

    source = detect_hdf5(path, files=files)
    if source is None or source.layout in layouts:
        return source
    source.close()
    return None


class HDF5Kind(ArrayKind):
    def open(self, path: Path) -> ArraySource | None:
        return hdf5_of(path, self.layouts)

    def blocks(self, handle: ArraySource) -> list[Path]:
        return list(getattr(handle, "files"))  # noqa: B009 - an HDF5Source's

    def open_block(self, src: Path, files: list[Path]) -> ArraySource | None:
        return hdf5_of(src, self.layouts, files)
