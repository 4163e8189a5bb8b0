"""The replay / evaluation results layout: the contract between whoever replays or evaluates (issue #5) and
`stats` / `view`.

A results directory holds three files:

* `summary.json`: `{"format": "openral-results/1", "kind": "replay" | "eval", "dataset": "<path of the
  dataset that was replayed or evaluated>", "label": "<free text>", ...}`; other keys are kept as they are
  (what replay writes there, per mode: `replay/summary.py`). Readers go through `Results.kind`, `.dataset` and
  `.label`.
* `episodes.parquet`: one row per episode, columns `EPISODE_SCHEMA` (success is nullable: unknown stays NULL).
* `steps.parquet`: one row per replayed step, columns `STEP_SCHEMA`.

`action_error` is the Euclidean norm of (replayed action - recorded action) at that step; `divergence` is the
Euclidean norm of (replayed state - recorded state) after that step. Write results only through
`write_results`, so the files always match these schemas.

Optional columns (`EPISODE_OPTIONAL`, `STEP_OPTIONAL`) carry the per-dimension detail replay computes; a writer
that does not have them leaves them out and they are stored as NULL, and readers never require them:
* episodes: `state_max_abs` (per state dimension, max |replayed - recorded| over the episode),
  `first_divergence_frame` (first frame whose max-abs state error exceeds the tolerance, NULL if none),
  `object_error_initial` (largest object position error, metres, right after restoring the initial state),
  `action_mse` / `action_mae` (per action dimension, over the compared steps);
* steps: `max_abs_error` (max over dimensions of the compared vector: state in replay, action in eval),
  `state_abs_error` / `action_abs_error` (per dimension |replayed - recorded|).
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Literal, cast

import pyarrow as pa
import pyarrow.parquet as pq

from openral_data.errors import OutputExists, ResultsError
from openral_data.formats import atomic
from openral_data.formats.jsonfile import read_json
from openral_data.formats.parquetfile import read_schema

FORMAT = "openral-results/1"
SUMMARY = "summary.json"
EPISODES = "episodes.parquet"
STEPS = "steps.parquet"
Kind = Literal["replay", "eval"]
KINDS: tuple[Kind, ...] = ("replay", "eval")

EPISODE_SCHEMA = pa.schema(
    [
        pa.field("episode_index", pa.int64(), nullable=False),
        pa.field("steps", pa.int64(), nullable=False),
        ("success_recorded", pa.bool_()),
        ("success_replayed", pa.bool_()),
        ("action_error_mean", pa.float64()),
        ("action_error_max", pa.float64()),
        ("divergence_mean", pa.float64()),
        ("divergence_max", pa.float64()),
        ("divergence_final", pa.float64()),
    ]
)
EPISODE_OPTIONAL = pa.schema(
    [
        ("state_max_abs", pa.list_(pa.float64())),
        ("first_divergence_frame", pa.int64()),
        ("object_error_initial", pa.float64()),
        ("action_mse", pa.list_(pa.float64())),
        ("action_mae", pa.list_(pa.float64())),
    ]
)
STEP_SCHEMA = pa.schema(
    [
        pa.field("episode_index", pa.int64(), nullable=False),
        pa.field("frame_index", pa.int64(), nullable=False),
        ("action_error", pa.float64()),
        ("divergence", pa.float64()),
    ]
)
STEP_OPTIONAL = pa.schema(
    [
        ("max_abs_error", pa.float64()),
        ("state_abs_error", pa.list_(pa.float64())),
        ("action_abs_error", pa.list_(pa.float64())),
    ]
)


@dataclass(frozen=True)
class Results:
    root: Path
    summary: Mapping[str, object]  # summary.json, `kind` checked

    @property
    def kind(self) -> Kind:
        return cast(Kind, self.summary["kind"])

    @property
    def dataset(self) -> str | None:
        """The path of the dataset replayed or evaluated (None if the writer gave none)."""
        ref = self.summary.get("dataset")
        return ref if isinstance(ref, str) else None

    @property
    def label(self) -> str:
        return str(self.summary.get("label") or self.root.name)

    @property
    def episodes_path(self) -> Path:
        return self.root / EPISODES

    @property
    def steps_path(self) -> Path:
        return self.root / STEPS


def write_results(root: Path, summary: Mapping[str, object], episodes: pa.Table, steps: pa.Table) -> Results:
    """Write a results directory atomically file by file (summary.json last); refuses to overwrite one."""
    if (root / SUMMARY).exists():
        raise OutputExists(f"{root}: already holds results; refusing to overwrite them")
    if summary.get("kind") not in KINDS:
        raise ResultsError(f"{root / SUMMARY}: kind: must be one of {', '.join(KINDS)}")
    full = {"format": FORMAT, **summary}
    ep = _conform(episodes, EPISODE_SCHEMA, root / EPISODES, EPISODE_OPTIONAL)
    st = _conform(steps, STEP_SCHEMA, root / STEPS, STEP_OPTIONAL)
    root.mkdir(parents=True, exist_ok=True)
    atomic.write_with(root / EPISODES, lambda p: pq.write_table(ep, p))
    atomic.write_with(root / STEPS, lambda p: pq.write_table(st, p))
    atomic.write_bytes(root / SUMMARY, json.dumps(full, indent=2).encode())
    return Results(root, full)


def _conform(table: pa.Table, schema: pa.Schema, path: Path, optional: pa.Schema | None = None) -> pa.Table:
    optional = optional if optional is not None else pa.schema([])
    missing = [f.name for f in schema if f.name not in table.column_names]
    extra = [c for c in table.column_names if c not in schema.names and c not in optional.names]
    if missing or extra:
        raise ResultsError(f"{path}: columns: missing {missing or '-'}, unexpected {extra or '-'}")
    for f in optional:
        if f.name not in table.column_names:
            table = table.append_column(f.name, pa.nulls(table.num_rows, f.type))
    full = pa.schema([*schema, *optional])
    try:
        return table.select(full.names).cast(full)
    except (pa.ArrowInvalid, pa.ArrowTypeError, ValueError) as exc:
        raise ResultsError(f"{path}: {exc}") from None


def is_results_dir(path: Path) -> bool:
    return (path / SUMMARY).is_file()


def open_results(root: Path) -> Results:
    """Open and validate a results directory; every problem names the file and the field."""
    path = root / SUMMARY
    try:
        summary = read_json(path)
    except FileNotFoundError:
        raise ResultsError(f"{root}: not a results directory (no {SUMMARY})") from None
    if not isinstance(summary, dict):
        raise ResultsError(f"{path}: expected a JSON object")
    if summary.get("format") != FORMAT:
        raise ResultsError(f"{path}: format: expected {FORMAT!r}, got {summary.get('format')!r}")
    if summary.get("kind") not in KINDS:
        raise ResultsError(f"{path}: kind: must be one of {', '.join(KINDS)}")
    for name, schema in ((EPISODES, EPISODE_SCHEMA), (STEPS, STEP_SCHEMA)):
        file = root / name
        if not file.is_file():
            raise ResultsError(f"{file}: missing")
        have = read_schema(file)
        for f in schema:
            if f.name not in have.names:
                raise ResultsError(f"{file}: {f.name}: missing column")
            if not have.field(f.name).type.equals(f.type):
                raise ResultsError(f"{file}: {f.name}: type {have.field(f.name).type}, expected {f.type}")
    return Results(root, summary)
