"""The robomimic family of HDF5 files (robomimic / robosuite `data/demo_N`, LIBERO, MimicGen / Isaac Lab
recorder), a file or a folder of them: split by file; the starting mapping from `obs/*`, `actions`, the env
name or language instruction, `rewards` and `dones` (`array_mapping.robomimic_mapping`)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from openral_data.convert.kinds.arrays import ArrayKind, LayoutMapping
from openral_data.formats.episodic import ArrayEpisode, ArraySource

if TYPE_CHECKING:
    from openral_data.formats.hdf5 import HDF5Source


def hdf5_of(path: Path, layouts: tuple[str, ...], files: list[Path] | None = None) -> HDF5Source | None:
    """`path` (only `files` of it) as an HDF5 source of one of `layouts`; None when it holds no HDF5 file or
    another layout (an HDF5 file of no known layout is one line, whichever HDF5 kind looks first)."""
    from openral_data.formats.hdf5 import detect_hdf5  # h5py only when a source is looked at

    source = detect_hdf5(path, files=files)
    if source is None or source.layout in layouts:
        return source
    source.close()
    return None


class RobomimicKind(ArrayKind):
    name = "hdf5-robomimic"
    summary = "HDF5: robomimic / robosuite, LIBERO, MimicGen / Isaac Lab (data/demo_N), a file or a folder"
    layouts = ("robomimic", "libero", "mimicgen")

    def open(self, path: Path) -> ArraySource | None:
        return hdf5_of(path, self.layouts)

    def blocks(self, handle: ArraySource) -> list[Path]:
        return list(getattr(handle, "files"))  # noqa: B009 - an HDF5Source's

    def open_block(self, src: Path, files: list[Path]) -> ArraySource | None:
        return hdf5_of(src, self.layouts, files)

    def layout_mapping(self, source: ArraySource, first: ArrayEpisode) -> LayoutMapping:
        from openral_data.convert.array_mapping import robomimic_mapping

        return robomimic_mapping(source, first)
