"""D4RL's flat HDF5 (`Farama-Foundation/D4RL:d4rl/offline_env.py`'s `get_dataset`, the files its
`Farama-Foundation/D4RL:scripts/generation/*` write): one file, every per-step array a root dataset of N rows
(`observations`, `actions`, `rewards`, `terminals`, `timeouts`, optionally `next_observations` and `infos/*`;
`metadata/*` is not per step), no episode groups.

Episodes are cut where the file says one ends: after every row whose `terminals` or `timeouts` is set (an
environment's terminal state, or its time limit), as D4RL's own `sequence_dataset` cuts them. The rows after the
last such row are a last, unfinished episode (the file ends there), kept. The cut is read in bounded chunks of the
two flag arrays; every episode is then a window of rows of the same root datasets (`windows`).

Neither flag means success (a locomotion terminal is a fall; a timeout is the clock): success is read only from a
per-step `infos/success` or `infos/goal_achieved` when the file has one (the starting mapping's choice).
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from openral_data.errors import DatasetError
from openral_data.formats.episodic import EpisodeMeta
from openral_data.formats.hdf5.files import MAX_STEPS, rows_of, walk_datasets
from openral_data.formats.hdf5.windows import Column, WindowEpisode

FLAGS = ("terminals", "timeouts")
SKIPPED = ("metadata",)  # D4RL's per-file metadata group: not per step
FLAG_CHUNK = 1 << 20  # rows of the flag arrays read at once


def is_d4rl(f: h5py.File) -> bool:
    """Root datasets `observations` and `actions` and at least one of `terminals` / `timeouts`."""

    def dataset(key: str) -> bool:
        return f.get(key, getclass=True) is h5py.Dataset

    return dataset("observations") and dataset("actions") and any(dataset(k) for k in FLAGS)


class D4rlFile:
    """One D4RL file (the `ArraySource` of one file): its episodes are row ranges cut at terminals / timeouts."""

    layout = "d4rl"
    fps: float | None = None  # D4RL stores no step rate

    def __init__(self, path: Path, f: h5py.File) -> None:
        self.path = path
        self.f = f
        self.rows = rows_of(f, "actions", path)
        if self.rows > MAX_STEPS:
            raise DatasetError(f"{path}: actions: {self.rows} rows (over {MAX_STEPS})", code="dataset.source.shape")
        self.columns = {key: Column(ds, 0, self.rows) for key, ds in walk_datasets(f, path, SKIPPED)}

    def _ends(self) -> list[int]:
        """The rows after which an episode ends (terminals | timeouts set), in order."""
        flags = [k for k in FLAGS if k in self.columns]
        for key in flags:
            ds = self.columns[key].ds
            if ds.shape != (self.rows,) or ds.dtype.kind not in "biuf":
                raise DatasetError(f"{self.path}: {key}: shape {ds.shape} {ds.dtype}, not one flag a row "
                                   f"({self.rows} rows, as actions)", code="dataset.source.shape")  # fmt: skip
        ends: list[int] = []
        for start in range(0, self.rows, FLAG_CHUNK):
            stop = min(self.rows, start + FLAG_CHUNK)
            done = np.zeros(stop - start, bool)
            for key in flags:
                done |= _rows(self.columns[key].ds, start, stop, self.path) != 0
            ends += (np.flatnonzero(done) + start).tolist()
        return ends

    def episodes(self) -> Iterator[WindowEpisode]:
        flagged = [end + 1 for end in self._ends()]
        last = [self.rows] if self.rows > (flagged[-1] if flagged else 0) else []  # the unfinished last episode
        start = 0
        for index, stop in enumerate(flagged + last):
            columns = {key: Column(c.ds, start, c.rows, c.encoding) for key, c in self.columns.items()}
            ended = "file end" if index == len(flagged) else "terminals/timeouts"
            meta = EpisodeMeta(None, {"rows": [start, stop], "ended": ended})
            yield WindowEpisode(f"episode_{index}", self.path, stop - start, columns, meta)
            start = stop

    def close(self) -> None:
        self.f.close()


def _rows(ds: h5py.Dataset, start: int, stop: int, path: Path) -> Any:
    try:
        return np.asarray(ds[start:stop])
    except (OSError, ValueError, RuntimeError, TypeError) as exc:
        raise DatasetError(f"{path}: {ds.name.lstrip('/')}: cannot read rows {start}:{stop}: {exc}",
                           code="dataset.source.read") from None  # fmt: skip
