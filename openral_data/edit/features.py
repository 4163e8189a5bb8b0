"""`features remove`: write a dataset without some of its features; `features rename`: with one under a new key.

Rename (`edit.renames` says which keys may be renamed to which): a video camera's packets are copied into
`videos/NEW/...`, never re-encoded; a column is copied under its new name; every statistic is carried over.

A video camera's files are not copied, a `dtype: image` camera's or a numeric feature's column is dropped
(`observation.environment_state`, `next.reward`, `next.success`, `next.done`, …); `info.json`, `stats.json` and
the episodes' `stats/*` columns lose them too. Without `next.success` the episodes' success becomes unknown
(`openral.success` NULL: the success rule has nothing left to read). Refused: the columns every LeRobot v3
dataset has (`timestamp`, `frame_index`, `episode_index`, `index`, `task_index`), and `observation.state` and
`action`, which our writer writes into every dataset (it has no layout without them).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from pathlib import Path

from openral_data.edit.ops import EditResult, Rewrite, summed_histograms, write_edit
from openral_data.edit.source import EpisodeData, SourceDataset
from openral_data.errors import UsageError
from openral_data.formats.lerobot_v3.features import ACTION, DEFAULT_FEATURES, STATE
from openral_data.text import did_you_mean


def remove(dataset: Path, keys: Sequence[str], out: Path | None, in_place: bool = False) -> EditResult:
    """Write `dataset` without the features `keys` (info.json keys, e.g. `observation.images.wrist`)."""
    src = SourceDataset(dataset)
    drop = _checked(src, keys)
    features = {k: f for k, f in src.features.items() if k not in drop}
    cameras = {name: shape for name, shape in src.schema.cameras.items() if src.camera_key[name] not in drop}
    schema = dataclasses.replace(
        src.schema, cameras=cameras, has_reward="next.reward" in features, has_success="next.success" in features
    )
    hist = summed_histograms([src])  # every episode is kept: the remaining cameras' histograms stay exact

    def without(ep: EpisodeData) -> EpisodeData:
        return dataclasses.replace(
            ep,
            videos={n: v for n, v in ep.videos.items() if n in cameras},
            image_stats={n: s for n, s in ep.image_stats.items() if n in cameras},
            columns={k: c for k, c in ep.columns.items() if k not in drop},
            column_stats={k: s for k, s in ep.column_stats.items() if k not in drop},
        )

    rewrite = Rewrite(
        transform=without,
        schema=schema,
        features=features,
        image_hist=None if hist is None else {n: acc for n, acc in hist.items() if n in cameras},
    )
    return write_edit([(src, e) for e in range(src.total)], dataset, out, in_place, "features remove", rewrite)


def rename(dataset: Path, old: str, new: str, out: Path | None, in_place: bool = False) -> EditResult:
    """Write `dataset` with the feature `old` under the key `new` (a camera's files moved, nothing re-encoded)."""
    src = SourceDataset(dataset, {old: new}, ("--from", "--to"))
    rewrite = Rewrite(image_hist=summed_histograms([src]), details={"renamed": {old: new}})
    return write_edit([(src, e) for e in range(src.total)], dataset, out, in_place, "features rename", rewrite)


def _checked(src: SourceDataset, keys: Sequence[str]) -> set[str]:
    if not keys:
        raise UsageError("--feature: give at least one feature to remove")
    for key in keys:
        if key not in src.features:
            raise UsageError(
                f"--feature: {src.root} has no feature {key!r}{did_you_mean(key, src.features)} "
                f"(its features: {', '.join(src.features)})"
            )
        if key in DEFAULT_FEATURES:
            raise UsageError(f"--feature: {key} is a column every LeRobot v3 dataset has; it cannot be removed")
        if key in (STATE, ACTION):
            raise UsageError(
                f"--feature: {key} cannot be removed: openral-data writes {STATE} and {ACTION} into every dataset"
            )
    return set(keys)
