"""Episodes whose per-step arrays are row windows of HDF5 datasets, for the layouts where a dataset's rows are not
exactly an episode's steps: D4RL's flat file (every episode a range of rows of the same root datasets), Minari and
ManiSkill (observations have one row more than actions: the reset's observation first; Minari's infos too).

A `Column` says which rows of a dataset are the episode's steps (`first`: the dataset's row of step 0) and how many
rows the dataset must have (`rows`); a dataset with another row count is not a per-step array of the episode (left
out and said why, as `files.episode_specs` does). Reads are bounded as every HDF5 read is (`files.read_rows`).
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import h5py
import numpy.typing as npt

from openral_data.errors import DatasetError
from openral_data.formats.episodic import ArraySpec, Encoding, EpisodeMeta
from openral_data.formats.hdf5.files import read_rows, step_spec


@dataclass(frozen=True)
class Column:
    """One per-step array: `ds` rows `first .. first + length` are the episode's steps; `ds` must have `rows`."""

    ds: h5py.Dataset
    first: int
    rows: int
    encoding: Encoding = "raw"


def window_specs(columns: dict[str, Column], file: Path) -> tuple[dict[str, ArraySpec], dict[str, str]]:
    """The specs of `columns` (key -> spec) and the datasets that are not per-step arrays (key -> why)."""
    specs: dict[str, ArraySpec] = {}
    ignored: dict[str, str] = {}
    for key, col in columns.items():
        where = f"{file}: {col.ds.name.lstrip('/')}: "
        try:
            specs[key] = step_spec(col.ds, key, col.rows, file, col.encoding)
        except DatasetError as exc:
            ignored[key] = str(exc).removeprefix(where)
    return specs, ignored


class WindowEpisode:
    """An episode of `length` steps whose arrays are `columns` (`ArrayEpisode`); its specs are decided when it
    is made (a row count that is not the episode's: `meta.ignored`)."""

    def __init__(self, name: str, file: Path, length: int, columns: dict[str, Column], meta: EpisodeMeta) -> None:
        self.name = name
        self.file = file
        self.length = length
        self.columns = columns
        self.meta = meta
        self._specs, ignored = window_specs(columns, file)
        meta.ignored.update(ignored)

    def specs(self) -> list[ArraySpec]:
        return list(self._specs.values())

    def read(self, key: str, start: int, stop: int) -> npt.NDArray[Any]:
        specs = self._specs
        spec = specs.get(key)
        if spec is None and key in self.meta.ignored:
            raise DatasetError(f"{self.file}: {self.name}/{key}: not a per-step array: {self.meta.ignored[key]}",
                               code="dataset.source.shape")  # fmt: skip
        if spec is None:
            raise DatasetError(f"{self.file}: {self.name}/{key}: missing (per-step arrays here: "
                               f"{', '.join(specs) or '-'})", code="dataset.source.key")  # fmt: skip
        col = self.columns[key]
        return read_rows(col.ds, col.first + start, col.first + stop, self.file, spec.encoding, spec)


def episode_columns(
    items: Iterable[tuple[str, h5py.Dataset]], length: int, *, plus_one: dict[str, int], encodings: dict[str, Encoding]
) -> dict[str, Column]:
    """The columns of an episode of `length` steps from its datasets (slash key, dataset): a dataset of `length`
    rows is read as it is; one of `length + 1` rows whose key starts with a prefix in `plus_one` is read from that
    prefix's first row (0: the last row, the state after the last step, is left out; 1: the first row, the reset's,
    is); any other row count is checked against `length` (and so said not per-step)."""
    out: dict[str, Column] = {}
    for key, ds in items:
        rows = int(ds.shape[0]) if ds.shape else 0
        first = next((f for prefix, f in plus_one.items() if key == prefix or key.startswith(prefix + "/")), None)
        if first is not None and rows == length + 1:
            out[key] = Column(ds, first, length + 1, encodings.get(key, "raw"))
        else:
            out[key] = Column(ds, 0, length, encodings.get(key, "raw"))
    return out
