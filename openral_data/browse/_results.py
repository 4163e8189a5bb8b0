"""Replay / eval results shown with the dataset they were computed on (`browse DATASET RESULTS`): per-episode
columns for the table and per-frame error series for the episode page. A results folder is untrusted input like a
dataset: only its two parquet files are read, at their fixed names (`paths.contained`: a symlink out is refused),
regular files only, through `formats/parquetfile`; an episode's steps by its row groups only (`EpisodeRows`)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pyarrow as pa

from openral_data.browse._rows import EpisodeRows
from openral_data.errors import UsageError
from openral_data.formats.parquetfile import read_table
from openral_data.formats.results import EPISODES, STEPS, Results
from openral_data.metrics.sources import DatasetSource
from openral_data.paths import contained

# per-episode columns shown, in this order, when the results hold a value for at least one episode
SHOWN = (
    "reproduced",
    "success_replayed",
    "first_divergence_frame",
    "state_max_abs",
    "divergence_max",
    "action_error_mean",
    "action_mse",
    "action_mae",
)
STEP_SERIES = ("action_error", "divergence", "max_abs_error")
_LISTS = ("state_max_abs", "action_mse", "action_mae")  # per dimension: the table shows max (state) or mean


@dataclass
class ResultSet:
    """One results folder attached to a dataset; its table columns are keyed `r<number>.<column>`."""

    results: Results
    number: int
    table: pa.Table = field(init=False)  # episode_index + the shown columns (keys), one row per episode
    columns: list[dict[str, str]] = field(init=False)  # {"key", "label"} per shown column
    by_episode: dict[int, dict[str, Any]] = field(init=False)
    rows: EpisodeRows = field(default_factory=EpisodeRows, init=False)

    def __post_init__(self) -> None:
        path = contained(self.results.root, EPISODES, f"{self.results.root}: {EPISODES}")
        values = _episode_values(read_table(path).to_pylist(), self.results.kind)
        shown = [c for c in SHOWN if any(v is not None for v in values[c])]
        self.columns = [
            {"key": self.key(c), "label": f"{self.results.label}: {_label(c, self.results.kind)}"} for c in shown
        ]
        self.table = pa.table({"episode_index": values["episode_index"], **{self.key(c): values[c] for c in shown}})
        self.by_episode = {row["episode_index"]: row for row in self.table.to_pylist()}

    def facts(self, episode: int) -> dict[str, Any]:
        """The episode's shown columns by label (empty when the results do not hold the episode)."""
        row = self.by_episode.get(episode)
        return {} if row is None else {c["label"]: row[c["key"]] for c in self.columns}

    def key(self, column: str) -> str:
        return f"r{self.number}.{column}"

    @property
    def view(self) -> str:
        """The name the table is registered under on the catalog's DuckDB connection."""
        return f"openral_browse_r{self.number}"

    def series(self, episode: int, frames: list[int]) -> list[dict[str, Any]]:
        """The episode's per-step errors, one series per `STEP_SERIES` column holding a value, aligned on the
        dataset's `frames` (null where no step was compared)."""
        path = contained(self.results.root, STEPS, f"{self.results.root}: {STEPS}")
        table = self.rows.read(path, episode, ["frame_index", *STEP_SERIES])
        at = {f: k for k, f in enumerate(frames)}
        feature = f"{self.results.label} ({self.results.kind})"
        out = []
        for name in STEP_SERIES:
            values: list[float | None] = [None] * len(frames)
            for frame, v in zip(table.column("frame_index").to_pylist(), table.column(name).to_pylist(), strict=True):
                if frame in at and v is not None:
                    values[at[frame]] = float(v)
            if any(v is not None for v in values):
                out.append({"feature": feature, "name": name, "values": values})
        return out


def _label(column: str, kind: str) -> str:
    if column == "success_replayed":
        return "success (policy)" if kind == "eval" else "success (replayed)"
    if column == "state_max_abs":
        return "state max |err|"
    if column in ("action_mse", "action_mae"):
        return f"{column} (mean over dims)"
    return column.replace("_", " ")


def _episode_values(rows: list[dict[str, Any]], kind: str) -> dict[str, list[Any]]:
    """The shown columns per episode (the first row of an episode repeated in the file wins)."""
    seen: set[int] = set()
    out: dict[str, list[Any]] = {c: [] for c in ("episode_index", *SHOWN)}
    for row in rows:
        if row["episode_index"] in seen:
            continue
        seen.add(row["episode_index"])
        out["episode_index"].append(row["episode_index"])
        for c in SHOWN:
            out[c].append(_value(row, c, kind))
    return out


def _value(row: dict[str, Any], column: str, kind: str) -> Any:
    if column == "reproduced":  # replay's rule (replay/summary.py): within tolerance throughout, same outcome
        if kind != "replay":
            return None
        recorded, replayed = row.get("success_recorded"), row.get("success_replayed")
        agrees = recorded is None or replayed is None or recorded == replayed
        return row.get("first_divergence_frame") is None and agrees
    value = row.get(column)
    if column in _LISTS:
        finite = [float(v) for v in value or [] if v is not None]
        if not finite:
            return None
        return max(finite) if column == "state_max_abs" else sum(finite) / len(finite)
    return value


def attach(datasets: Sequence[DatasetSource], results: Sequence[Results]) -> list[list[Results]]:
    """Each results folder with the dataset it was computed on: the one its summary.json names (same folder after
    resolving), else the only dataset given; otherwise refused in one line (give that dataset too)."""
    out: list[list[Results]] = [[] for _ in datasets]
    roots = [ds.root.resolve() for ds in datasets]
    for r in results:
        named = Path(r.dataset).resolve() if r.dataset is not None else None
        if named in roots:
            out[roots.index(named)].append(r)
        elif len(datasets) == 1:
            out[0].append(r)
        else:
            raise UsageError(
                f"browse: {r.root}: results of dataset {r.dataset!r}, which is not among the datasets given; "
                "give it too (browse DATASET RESULTS)"
            )
    return out
