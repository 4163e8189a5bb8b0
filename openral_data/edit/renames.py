"""Feature renames (`features rename`, `episodes merge --rename`): which keys may be renamed to which, and a
dataset's info.json features under their new keys.

A rename changes a feature's key only: a video camera's files move to `videos/NEW/...` (their packets copied),
a `dtype: image` camera's or a numeric column's parquet column is renamed, and info.json, stats.json and the
episodes' `videos/KEY/...` and `stats/KEY/...` columns follow (our writer names them all from the key). The
columns every LeRobot v3 dataset has (`timestamp`, `frame_index`, `episode_index`, `index`, `task_index`), the
`task` lerobot's loader adds to every item, `observation.state` and `action` (our writer writes both into every
dataset) and the outcomes it writes by name (`next.reward`, `next.done`, `next.success`) are neither renamed nor
taken as new names. A new key must be one path component (it names a folder under `videos/`) and new to the
dataset.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from openral_data.errors import UsageError
from openral_data.formats.lerobot_v3.features import ACTION, DEFAULT_FEATURES, OUTCOME_FEATURES, STATE

RESERVED = (*DEFAULT_FEATURES, "task", STATE, ACTION, *OUTCOME_FEATURES)


def parse_pair(text: str, flag: str) -> tuple[str, str]:
    """`OLD=NEW` -> (OLD, NEW), one line for anything else."""
    old, sep, new = text.partition("=")
    if not sep or not old.strip() or not new.strip():
        raise UsageError(f"{flag}: {text!r} is not OLD=NEW")
    return old.strip(), new.strip()


def check_renames(
    features: Mapping[str, Any], renames: Mapping[str, str], where: str, flags: tuple[str, str] = ("--rename",) * 2
) -> None:
    """Refuse in one line a rename of an absent or reserved key, to a reserved, taken, repeated or unsafe key
    (`flags`: the options that gave the old and the new key, named in the line)."""
    targets: list[str] = list(renames.values())
    of_old, of_new = flags
    for old, new in renames.items():
        if old not in features:
            raise UsageError(f"{of_old}: {where} has no feature {old!r} (its features: {', '.join(features)})")
        for flag, key in ((of_old, old), (of_new, new)):
            if key in RESERVED:
                raise UsageError(f"{flag}: {key} is a name openral-data and lerobot reserve; it cannot be renamed")
        if not new or new in (".", "..") or any(c in new for c in "/\\\x00") or not new.isprintable():
            raise UsageError(f"{of_new}: {new!r} cannot be a feature key (it names a folder under videos/)")
        if new in features and new not in renames:
            raise UsageError(f"{of_new}: {where} already has a feature {new!r}; renaming {old} to it would collide")
        if targets.count(new) > 1:
            raise UsageError(f"{of_new}: {new!r} is the new name of more than one feature")


def renamed(features: Mapping[str, Any], renames: Mapping[str, str]) -> dict[str, Any]:
    """`features` with the keys `renames` names replaced, each in its place (info.json order is kept)."""
    return {renames.get(key, key): value for key, value in features.items()}


def as_mapping(pairs: Sequence[tuple[str, str]], flag: str) -> dict[str, str]:
    """(OLD, NEW) pairs as a mapping, one line when an OLD is given twice."""
    out: dict[str, str] = {}
    for old, new in pairs:
        if old in out:
            raise UsageError(f"{flag}: {old} is renamed twice")
        out[old] = new
    return out
