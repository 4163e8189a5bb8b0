"""Episode outcomes -> the results layout of `formats/results.py` (episodes.parquet + steps.parquet)."""

from __future__ import annotations

from collections.abc import Sequence

import pyarrow as pa

from openral_data.replay.outcome import F64, EpisodeOutcome


def _stat(values: F64 | None, how: str) -> float | None:
    if values is None or values.size == 0:
        return None
    return float(values.mean() if how == "mean" else values.max())


def _mse(abs_error: F64 | None) -> list[float] | None:
    return None if abs_error is None or abs_error.size == 0 else (abs_error**2).mean(axis=0).tolist()


def _mae(abs_error: F64 | None) -> list[float] | None:
    return None if abs_error is None or abs_error.size == 0 else abs_error.mean(axis=0).tolist()


def episodes_table(outcomes: Sequence[EpisodeOutcome]) -> pa.Table:
    rows = []
    for o in outcomes:
        div, err = o.divergence, o.action_error
        rows.append(
            {
                "episode_index": o.index,
                "steps": o.steps,
                "success_recorded": o.success_recorded,
                "success_replayed": o.success_replayed,
                "action_error_mean": _stat(err, "mean"),
                "action_error_max": _stat(err, "max"),
                "divergence_mean": _stat(div, "mean"),
                "divergence_max": _stat(div, "max"),
                "divergence_final": None if div is None or div.size == 0 else float(div[-1]),
                "state_max_abs": None
                if o.state_abs is None or o.state_abs.size == 0
                else o.state_abs.max(axis=0).tolist(),
                "first_divergence_frame": o.first_divergence_frame,
                "object_error_initial": o.object_error_initial,
                "action_mse": _mse(o.action_abs),
                "action_mae": _mae(o.action_abs),
            }
        )
    return pa.Table.from_pylist(rows, schema=_episode_schema())


def steps_table(outcomes: Sequence[EpisodeOutcome]) -> pa.Table:
    cols: dict[str, list[object]] = {k: [] for k in _step_schema().names}
    for o in outcomes:
        n = len(o.frames)
        div, err = o.divergence, o.action_error
        cols["episode_index"] += [o.index] * n
        cols["frame_index"] += o.frames.tolist()
        cols["divergence"] += div.tolist() if div is not None else [None] * n
        cols["action_error"] += err.tolist() if err is not None else [None] * n
        vector = o.state_abs if o.state_abs is not None else o.action_abs
        cols["max_abs_error"] += vector.max(axis=1).tolist() if vector is not None and vector.size else [None] * n
        cols["state_abs_error"] += o.state_abs.tolist() if o.state_abs is not None else [None] * n
        cols["action_abs_error"] += o.action_abs.tolist() if o.action_abs is not None else [None] * n
    return pa.table(cols, schema=_step_schema())


def _episode_schema() -> pa.Schema:
    from openral_data.formats.results import EPISODE_OPTIONAL, EPISODE_SCHEMA

    return pa.schema([*EPISODE_SCHEMA, *EPISODE_OPTIONAL])


def _step_schema() -> pa.Schema:
    from openral_data.formats.results import STEP_OPTIONAL, STEP_SCHEMA

    return pa.schema([*STEP_SCHEMA, *STEP_OPTIONAL])
