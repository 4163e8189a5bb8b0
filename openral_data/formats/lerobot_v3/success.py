"""Whether each episode of a LeRobot v3 dataset (ours or lerobot's) succeeded: the one rule `info`, `stats`, `view`
and `convert` share.

A dataset with our `openral.success` episode column is read from it (NULL: unknown, e.g. a converted bag that
said nothing; its frames' `next.success` are then placeholders, not evidence). Without it, when the frames carry
lerobot's per-frame `next.success`, an episode succeeded if any of its frames says so (lerobot's own convention:
its eval counts an episode as a success when the environment reported success at any step, and its sim datasets,
e.g. `lerobot/pusht`, set `next.success` on the frames where the goal is reached). Else unknown (None), never
False.
"""

from __future__ import annotations

from pathlib import Path

import pyarrow as pa

from openral_data.errors import DatasetError
from openral_data.formats.lerobot_v3 import layout
from openral_data.formats.parquetfile import read_schema, read_table

EPISODE_SUCCESS = "openral.success"
FRAME_SUCCESS = "next.success"


def episode_successes(root: Path, episodes: pa.Table) -> dict[int, bool | None]:
    """Success of every episode in `episodes` (meta/episodes rows), by episode_index; None where unknown.
    A table without integer episode indices is a `DatasetError` naming meta/episodes (untrusted input)."""
    ids = _indices(episodes, root / "meta" / "episodes")
    if EPISODE_SUCCESS in episodes.column_names:  # ours: a NULL is an episode whose source said nothing
        ours = episodes.column(EPISODE_SUCCESS).to_pylist()
        return {e: None if v is None else bool(v) for e, v in zip(ids, ours, strict=True)}
    frames = _frame_successes(root)
    return {e: frames.get(e) for e in ids}


def _indices(table: pa.Table, source: Path) -> list[int]:
    if "episode_index" not in table.column_names:
        raise DatasetError(f"{source}: no column 'episode_index'", code="dataset.invalid")
    values = table.column("episode_index").to_pylist()
    if not all(isinstance(v, int) and not isinstance(v, bool) for v in values):
        raise DatasetError(f"{source}: episode_index: not all integers", code="dataset.invalid")
    return [int(v) for v in values]


def _frame_successes(root: Path) -> dict[int, bool]:
    """Per episode_index, whether any of its frames has `next.success` (episodes without frames are absent).
    Aggregated per episode in Arrow, one data file at a time: no per-frame value becomes a Python object."""
    import pyarrow.compute as pc  # here: ~60 ms to import, which `info` on our datasets (episode success) skips

    found: dict[int, bool] = {}
    for path in layout.data_files(root):
        if FRAME_SUCCESS not in read_schema(path).names:
            continue
        table = read_table(path, columns=["episode_index", FRAME_SUCCESS])
        if "episode_index" not in table.column_names:
            raise DatasetError(f"{path}: no column 'episode_index'", code="dataset.invalid")
        ids = table.column("episode_index")
        if not pa.types.is_integer(ids.type) or ids.null_count:
            raise DatasetError(f"{path}: episode_index: not all integers", code="dataset.invalid")
        column = table.column(FRAME_SUCCESS)
        try:
            if pa.types.is_list(column.type) or pa.types.is_fixed_size_list(column.type):  # shape (1,) as a list
                column = pc.list_flatten(column)
            flags = pc.fill_null(pc.cast(column, pa.bool_()), False)
        except pa.ArrowException as exc:
            raise DatasetError(f"{path}: {FRAME_SUCCESS}: not booleans ({exc})", code="dataset.invalid") from None
        if len(flags) != len(ids):
            raise DatasetError(f"{path}: {FRAME_SUCCESS}: not one value per frame", code="dataset.invalid")
        per_episode = pa.table({"e": ids, "s": flags}).group_by("e").aggregate([("s", "any")])
        for e, v in zip(per_episode.column("e").to_pylist(), per_episode.column("s_any").to_pylist(), strict=True):
            found[int(e)] = found.get(int(e), False) or bool(v)
    return found


def count_successes(successes: dict[int, bool | None]) -> tuple[int, int]:
    """(successes, episodes whose success is known)."""
    known = [v for v in successes.values() if v is not None]
    return sum(known), len(known)
