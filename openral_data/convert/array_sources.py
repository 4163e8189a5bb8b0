"""Which kind of source `convert SRC` was given: the array-source detectors, tried in order (`DETECTORS`; each
`detect(path) -> ArraySource | None`: None when `path` is not of its kind, a one-line error when it is but is
broken). A source no detector claims is read as bags (`convert.sources.find_bags`).

Zarr replay buffers and RLDS / TFDS episodes plug in here: add their `detect` to `DETECTORS`.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from openral_data.formats.episodic import ArraySource

Detector = Callable[[Path], ArraySource | None]


def _hdf5(path: Path) -> ArraySource | None:
    from openral_data.formats.hdf5 import detect_hdf5  # h5py only when a source is looked at

    return detect_hdf5(path)


DETECTORS: tuple[Detector, ...] = (_hdf5,)


def detect_array_source(path: Path) -> ArraySource | None:
    """The first detector's source for `path`, or None (then `path` is taken for bags)."""
    for detect in DETECTORS:
        source = detect(path)
        if source is not None:
            return source
    return None
