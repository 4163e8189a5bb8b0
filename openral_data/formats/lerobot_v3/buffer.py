"""One episode on its way into a LeRobot v3 dataset: its frame columns (`EpisodeBuffer`), the data table and
meta/episodes row built from them, and its per-feature statistics."""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt
import pyarrow as pa

from openral_data.formats.lerobot_v3.features import ACTION, STATE
from openral_data.formats.lerobot_v3.images import ENVIRONMENT_STATE
from openral_data.formats.lerobot_v3.masks import MaskColumn
from openral_data.formats.lerobot_v3.stats import Stats, numeric_stats
from openral_data.types import DatasetSchema, EpisodeStart


@dataclass
class EpisodeBuffer:
    """One episode's frame columns (one entry per frame) and what its meta/episodes row needs besides them."""

    start: EpisodeStart
    states: list[npt.NDArray[np.float32]] = field(default_factory=list)
    actions: list[npt.NDArray[np.float32]] = field(default_factory=list)
    rewards: list[float] = field(default_factory=list)
    dones: list[bool] = field(default_factory=list)
    successes: list[bool] = field(default_factory=list)
    task_indices: list[int] = field(default_factory=list)
    extras: dict[str, list[float]] = field(default_factory=dict)
    environment_states: list[npt.NDArray[np.float32]] = field(default_factory=list)  # with environment_state_names
    vectors: dict[str, list[npt.NDArray[Any]]] = field(default_factory=dict)  # the schema's frame_columns
    info: dict[str, Any] | None = None
    # whole columns of features the writer does not build itself (only with the writer's `features`; editing
    # carries e.g. `observation.environment_state` this way), each of the feature's Arrow type
    columns: dict[str, pa.Array] = field(default_factory=dict)
    # the episode statistics of those columns that are not numbers (a `dtype: image` feature's, as its source
    # has them): used instead of statistics computed from the column, and merged into the dataset's
    column_stats: dict[str, Stats] = field(default_factory=dict)
    # segmentation masks being recorded (the schema's `segmentation` cameras): PNGs that become `columns`
    masks: dict[str, MaskColumn] = field(default_factory=dict)


def base_row(
    index: int, ep: EpisodeBuffer, success: bool | None, tasks: dict[str, int], first_frame: int
) -> dict[str, Any]:
    """The episode's meta/episodes row before its file positions and statistics: `first_frame` is the
    dataset's frame count before it, `tasks` maps task strings to the indices in `ep.task_indices`."""
    inv = {i: t for t, i in tasks.items()}
    n = len(ep.states)
    return {
        "episode_index": index,
        "tasks": sorted({inv[i] for i in ep.task_indices}),
        "length": n,
        "dataset_from_index": first_frame,
        "dataset_to_index": first_frame + n,
        "openral.success": None if success is None else bool(success),
        "openral.seed": None if ep.start.seed is None else int(ep.start.seed),
        "openral.initial_state": json.dumps(ep.start.initial_state, sort_keys=True),
        "openral.episode_info": None if ep.info is None else json.dumps(ep.info, sort_keys=True),
    }


def episode_table(
    schema: DatasetSchema,
    features: dict[str, dict[str, Any]],
    data_schema: pa.Schema,
    index: int,
    ep: EpisodeBuffer,
    first_frame: int,
) -> pa.Table:
    """The episode's frames as a data table of `data_schema` (global `index` from `first_frame` on)."""
    n = len(ep.states)
    frame_index = np.arange(n, dtype=np.int64)
    cols: dict[str, pa.Array] = {
        STATE: _fixed_list(np.stack(ep.states)),
        ACTION: _fixed_list(np.stack(ep.actions)),
        "timestamp": pa.array((frame_index / schema.fps).astype(np.float32)),
        "frame_index": pa.array(frame_index),
        "episode_index": pa.array(np.full(n, index, dtype=np.int64)),
        "index": pa.array(first_frame + frame_index),
        "task_index": pa.array(np.asarray(ep.task_indices, dtype=np.int64)),
    }
    if "next.done" in features:
        cols["next.done"] = pa.array(np.asarray(ep.dones, dtype=bool))
    if schema.has_reward:
        cols["next.reward"] = pa.array(np.asarray(ep.rewards, dtype=np.float32))
    if schema.has_success:
        cols["next.success"] = pa.array(np.asarray(ep.successes, dtype=bool))
    for key in schema.frame_extras:
        cols[key] = pa.array(np.asarray(ep.extras.get(key, []), dtype=np.float32))
    if schema.environment_state_names:
        cols[ENVIRONMENT_STATE] = _fixed_list(np.stack(ep.environment_states))
    for col in schema.frame_columns:
        values = np.stack(ep.vectors[col.key]).reshape(n, col.dim)
        cols[col.key] = pa.array(values[:, 0].astype(bool)) if col.dtype == "bool" else _fixed_list(values)
    cols.update(ep.columns)
    return pa.table(cols, schema=data_schema)


def column_stats(ep: EpisodeBuffer, table: pa.Table) -> dict[str, Stats]:
    """The statistics of each of the episode's columns: the buffer's own where it has them, else computed."""
    return {
        k: ep.column_stats[k] if k in ep.column_stats else numeric_stats(_column_values(table, k))
        for k in table.column_names
    }


def _fixed_list(values: npt.NDArray[np.float32]) -> pa.Array:
    """(n, d) float32 -> fixed_size_list<float>[d]; d == 1 is a plain column, as lerobot types shape [1]."""
    flat = pa.array(np.ascontiguousarray(values, dtype=np.float32).ravel())
    return flat if values.shape[1] == 1 else pa.FixedSizeListArray.from_arrays(flat, values.shape[1])


def _column_values(table: pa.Table, key: str) -> npt.NDArray[Any]:
    col = table.column(key).combine_chunks()
    if pa.types.is_fixed_size_list(col.type):
        return np.asarray(col.flatten().to_numpy(zero_copy_only=False)).reshape(len(col), col.type.list_size)
    return np.asarray(col.to_numpy(zero_copy_only=False)).reshape(-1, 1)


def warm_up() -> None:
    """Pay pyarrow's one-time cost now (its first array imports pandas: about half a second): a recording
    calls this while its scene is being built, so its first episode's commit does not."""
    pa.array([0.0])
