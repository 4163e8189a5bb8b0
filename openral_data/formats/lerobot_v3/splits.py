"""info.json's `splits` (lerobot's format: split name -> ``"start:end"``, a range of episode indices) from the
episodes' own record of the split they came from (`openral.initial_state`'s ``split``, which `convert` sets from
an RLDS dataset's splits or a robomimic file's ``mask/train`` / ``mask/valid`` filter keys, ordering episodes by
split so each split is one contiguous range). A dataset whose episodes say no split is all ``train``."""

from __future__ import annotations

import json
from typing import Any

from openral_data.errors import DatasetError

SPLIT = "split"  # the key of an episode's initial_state naming its source split


def episode_split(row: dict[str, Any]) -> str | None:
    """The source split a meta/episodes row records, if any."""
    raw = row.get("openral.initial_state")
    if not isinstance(raw, str) or f'"{SPLIT}"' not in raw:
        return None
    try:
        state = json.loads(raw)
    except ValueError:
        return None
    value = state.get(SPLIT) if isinstance(state, dict) else None
    return value if isinstance(value, str) and value else None


def splits_of(rows: list[dict[str, Any]]) -> dict[str, str]:
    """The `splits` of a dataset whose meta/episodes rows are `rows`, in episode order: each split's contiguous
    run as ``"start:end"``; episodes that say no split are ``train``'s. A split whose episodes are not one run
    (several source files, each with its own filter keys) has each run named ``<name>``, ``<name>_2``, ... so no
    episode is put in a split it did not come from."""
    names = [episode_split(row) for row in rows]
    if not any(names):
        return {"train": f"0:{len(rows)}"}
    runs: list[tuple[str, int, int]] = []
    for i, name in enumerate(names):
        split = name or "train"
        if runs and runs[-1][0] == split:
            runs[-1] = (split, runs[-1][1], i + 1)
        else:
            runs.append((split, i, i + 1))
    out: dict[str, str] = {}
    for split, start, end in runs:
        key, k = split, 1
        while key in out:
            k += 1
            key = f"{split}_{k}"
        out[key] = f"{start}:{end}"
    return out


def range_splits(splits: object, where: str) -> dict[str, range]:
    """info.json's `splits` (None: none) as split name -> its range of episode indices; a value that is not
    ``"start:end"`` (0 <= start <= end) is one line naming `where`."""
    if splits is None:
        return {}
    if not isinstance(splits, dict):
        raise DatasetError(f"{where}: not a mapping of split names to 'start:end'", code="dataset.invalid")
    out: dict[str, range] = {}
    for name, span in splits.items():
        start, sep, end = str(span).partition(":")
        if not (sep and start.strip().isdigit() and end.strip().isdigit() and int(start) <= int(end)):
            raise DatasetError(f"{where}: {name}: {span!r} is not 'start:end'", code="dataset.invalid")
        out[str(name)] = range(int(start), int(end))
    return out
