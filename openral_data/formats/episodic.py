"""The face every episodic array source shows to `convert` and `info`: HDF5 (robomimic, LIBERO, MimicGen /
Isaac Lab, ALOHA/ACT), Zarr replay buffers (diffusion policy / UMI) and RLDS / TFDS episodes.

These sources hold episodes already on a step grid (one row per step), so they skip the bag aligner: a step is a
frame. Every per-step array is named by a slash path relative to its episode (``obs/agentview_image``,
``observations/images/top``, ``steps/observation/state``, ``action``), the names mapping files use for them.
Readers stream: `ArrayEpisode.read` returns the rows ``start:stop`` of one array (decoded pictures for
encoded images), so memory is bounded by the chunk a caller asks for, never by a file.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal, Protocol

import numpy.typing as npt

__all__ = ["ArrayEpisode", "ArraySource", "ArraySpec", "Encoding", "EpisodeMeta"]

# how a per-step array stores its rows: plain numbers, or one encoded picture per row (JPEG/PNG bytes, or an
# image array compressed per frame as ALOHA's compressed variant and RLDS's encoded images do)
Encoding = Literal["raw", "jpeg", "png", "image"]


@dataclass(frozen=True)
class ArraySpec:
    """One per-step array: its key, the dtype and shape of ONE step after decoding, and how it is stored."""

    key: str
    dtype: str  # numpy dtype name after decoding ("float32", "uint8", "bool", "bytes" for text)
    shape: tuple[int, ...]  # one step's shape after decoding; () for a scalar per step
    encoding: Encoding = "raw"


@dataclass
class EpisodeMeta:
    """What an episode says about itself beside its arrays (all optional)."""

    language: str | None = None  # task text / language instruction
    attrs: dict[str, Any] = field(default_factory=dict)  # e.g. env_args, problem_info, initial_state names
    # datasets of the episode that are not per-step arrays of it (key -> why: ragged, not numbers...): left out
    # of `specs()`, never read; a mapping that names one is told why
    ignored: dict[str, str] = field(default_factory=dict)
    # the source's split the episode belongs to (RLDS `train`/`val`, robomimic's `mask/train`/`mask/valid`);
    # sources yield episodes grouped by split, so each split is one contiguous range of the output
    split: str | None = None


class ArrayEpisode(Protocol):
    """One episode of an array source."""

    @property
    def name(self) -> str:
        """The episode's name in its source (``demo_3``, ``episode_0.hdf5``, ``12``)."""
        ...

    @property
    def length(self) -> int:
        """Its number of steps (every per-step array has this many rows)."""
        ...

    @property
    def meta(self) -> EpisodeMeta: ...

    def specs(self) -> list[ArraySpec]:
        """Its per-step arrays, in a stable order."""
        ...

    def read(self, key: str, start: int, stop: int) -> npt.NDArray[Any]:
        """Rows ``start:stop`` of one array, decoded (pictures as HxWxC uint8). Raises `DatasetError`
        (code ``dataset.source.*``) naming the file and key when the stored data is malformed."""
        ...


class ArraySource(Protocol):
    """A file or folder holding episodes of one layout."""

    @property
    def path(self) -> Path: ...

    @property
    def layout(self) -> str:
        """The recognised layout: ``robomimic``, ``libero``, ``mimicgen``, ``aloha``, ``zarr``, ``rlds``."""
        ...

    @property
    def fps(self) -> float | None:
        """The step rate the source declares, if it declares one."""
        ...

    def episodes(self) -> Iterator[ArrayEpisode]:
        """Its episodes in source order, each opened lazily."""
        ...

    def close(self) -> None: ...
