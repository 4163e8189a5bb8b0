"""Which kind of array source a path is: the one list of array-source detectors (`DETECTORS`), tried in order by
`convert SRC` and `info SRC` alike. Each is `detect(path) -> ArraySource | None`: None when `path` is not of its
kind, a one-line `DatasetError` when it is but is broken. A source no detector claims is read as bags
(`convert.sources.find_bags`) or a LeRobot dataset.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from openral_data.errors import DatasetError
from openral_data.formats.episodic import ArraySource

Detector = Callable[[Path], ArraySource | None]


def _hdf5(path: Path) -> ArraySource | None:
    from openral_data.formats.hdf5 import detect_hdf5  # h5py only when a source is looked at

    return detect_hdf5(path)


def _zarr(path: Path) -> ArraySource | None:
    from openral_data.formats.zarr_replay import detect  # zarr only when a source is looked at

    return detect(path)


def _rlds(path: Path) -> ArraySource | None:
    from openral_data.formats.rlds import detect

    return detect(path)


# HDF5 files and folders of them, Zarr replay buffers (.zarr folder, .zarr.zip), RLDS / TFDS build folders
DETECTORS: tuple[Detector, ...] = (_hdf5, _zarr, _rlds)


def detect_array_source(path: Path) -> ArraySource | None:
    """The first detector's source for `path`, or None (then `path` is taken for bags)."""
    for detect in DETECTORS:
        source = detect(path)
        if source is not None:
            return source
    return None


def block_files(source: ArraySource) -> list[Path]:
    """What `convert --workers` splits `source` by: its HDF5 files or RLDS shards; a Zarr store is one block."""
    if source.layout == "rlds":
        return list(getattr(source, "shards"))  # noqa: B009 - RldsSource's, without importing formats.rlds here
    files = getattr(source, "files", None)
    return list(files) if files else [source.path]


def open_block(src: Path, layout: str, files: list[Path]) -> ArraySource:
    """The part of the source `src` (of `layout`) that `files` (some of `block_files`) hold, for one worker."""
    if layout == "zarr":
        source = _zarr(src)
    elif layout == "rlds":
        from openral_data.formats.rlds import RldsSource

        whole = _rlds(src)
        source = RldsSource(whole.path, shards=files) if whole is not None else None
    else:
        from openral_data.formats.hdf5 import detect_hdf5

        source = detect_hdf5(src, files=files)
    if source is None:
        raise DatasetError(f"{src}: no longer a {layout} source", code="dataset.source.layout")
    return source
