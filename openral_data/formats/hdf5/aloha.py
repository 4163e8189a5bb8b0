"""ALOHA / ACT episodes: one `episode_N.hdf5` file per episode (`/observations/qpos`, `/observations/qvel`,
optionally `/observations/effort`, `/observations/images/<cam>`, `/action`, optionally `/base_action`; attrs `sim`
and, in the real-robot recorder, `compress`). With `compress` true each camera row is a JPEG zero-padded to the
longest one (uint8, one row per step); the padding is ignored when decoding (`/compress_len` is not needed).

ACT's and ALOHA's recorders store no step rate: the rate is the mapping's (`--fps`, or `fps:`).
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import h5py
import numpy.typing as npt

from openral_data.errors import DatasetError
from openral_data.formats.episodic import ArraySpec, Encoding, EpisodeMeta
from openral_data.formats.hdf5.files import (
    attr_scalar,
    episode_specs,
    open_file,
    read_key,
    rows_of,
    walk_datasets,
)

IMAGES = "observations/images"


def is_aloha(f: h5py.File) -> bool:
    """An `/observations` group with `qpos` or `images` (a missing `/action` is then the episode's error)."""
    obs = f.get("observations")
    return isinstance(obs, h5py.Group) and ("qpos" in obs or "images" in obs)


class AlohaEpisode:
    """One `episode_N.hdf5` (it is also the open file's episode)."""

    def __init__(self, path: Path, f: h5py.File) -> None:
        self.file = path
        self.f = f
        self.length = rows_of(f, "action", path)
        self.compressed = bool(attr_scalar(f, "compress"))
        self.meta = EpisodeMeta(None, {"sim": bool(attr_scalar(f, "sim")), "compress": self.compressed})
        self._specs: dict[str, ArraySpec] | None = None

    @property
    def name(self) -> str:
        return self.file.name

    def _encoding(self, key: str, ds: h5py.Dataset) -> Encoding:
        # the compressed variant: one padded JPEG per row (uint8, 2 dims); raw pictures are (T, H, W, 3)
        return "jpeg" if self.compressed and key.startswith(IMAGES + "/") and len(ds.shape) == 2 else "raw"

    def _all(self) -> dict[str, ArraySpec]:
        if self._specs is None:
            walked = walk_datasets(self.f, self.file, ("compress_len",))  # (cameras, steps): not per step
            items = ((key, ds, self._encoding(key, ds)) for key, ds in walked)
            self._specs, self.meta.ignored = episode_specs(items, self.length, self.file)
        return self._specs

    def specs(self) -> list[ArraySpec]:
        return list(self._all().values())

    def read(self, key: str, start: int, stop: int) -> npt.NDArray[Any]:
        return read_key(self.f, self._all(), key, start, stop, self.file, self.meta.ignored)


class AlohaFolder:
    """A folder of `episode_N.hdf5` files (or one such file), episodes in natural name order."""

    layout = "aloha"
    fps: float | None = None

    def __init__(self, path: Path, files: list[Path]) -> None:
        self.path = path
        self.files = files
        self._open: list[h5py.File] = []

    def episodes(self) -> Iterator[AlohaEpisode]:
        for file in self.files:
            f = open_file(file)
            self._open.append(f)
            if not is_aloha(f):
                raise DatasetError(f"{file}: /observations: missing (not an ALOHA episode)", code="dataset.source.key")
            try:
                yield AlohaEpisode(file, f)
            finally:
                f.close()
                self._open.remove(f)

    def close(self) -> None:
        for f in self._open:
            f.close()
        self._open.clear()
