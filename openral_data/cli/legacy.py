"""A LeRobot v2.0/v2.1 dataset given to a command declared `v2="upgrade"` (`cli/takes.py`: every edit,
`stats recompute`, `videos …`, `replay`, `quality`, `browse`) is read through a temporary upgrade:
`openral-data upgrade` (lerobot's own converter steps) writes it as v3.0 into a temporary folder, the command runs
on that, and the folder goes when the command ends. The source is only read; `--in-place` on a v2.x dataset is
refused (the edit writes v3.0, so it goes to `--out NEW`). Episode numbers the user typed (the declaration's
`episodes`) are the dataset's own (`episode_index`, which may have gaps: a subset kept from a larger dataset) and
are mapped to the upgrade's 0..n-1. docs/upgrade.md#other-commands-on-v2x-datasets.
"""

from __future__ import annotations

import tempfile
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from contextvars import ContextVar
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from openral_data.cli import terminal
from openral_data.cli.takes import Numbers, Takes
from openral_data.errors import EpisodeSelectionError, OpenralError, UsageError
from openral_data.formats.repo_id import resolve_dataset


@dataclass(frozen=True)
class Upgraded:
    """What a temporary upgrade was made from: the dataset as the user gave it, and its own episode numbers (the
    upgrade's episode e is OLD's `numbers[e]`)."""

    given: str
    numbers: tuple[int, ...]


_UPGRADED: ContextVar[dict[str, Upgraded] | None] = ContextVar("openral_upgraded", default=None)


def upgraded(path: Path) -> Upgraded | None:
    """While a command runs on temporary upgrades, what the one at `path` was made from; None for any other path
    (what the command prints about an episode can then be numbered as the user's)."""
    return (_UPGRADED.get() or {}).get(str(Path(path).resolve()))


@contextmanager
def read_as_v3(kwargs: dict[str, Any], takes: Takes) -> Iterator[None]:
    """While the block runs, each v2.x dataset `kwargs[takes.param]` names (one path or a list) is replaced by a
    temporary v3.0 upgrade of it, and the episode numbers typed for it by their upgrade's; anything else (v3, a
    path that is not a dataset) is left to the command."""
    given = kwargs[takes.param]
    items = list(given) if isinstance(given, list | tuple) else [given]
    versions = [_legacy(item) for item in items]
    if not any(versions):
        yield
        return
    old = next(item for item, v in zip(items, versions, strict=True) if v)
    if takes.writes == "new or in place" and kwargs.get("in_place"):
        raise UsageError(
            f"{old}: a LeRobot {_legacy(old)} dataset is not edited in place (the edit writes v3.0): give --out NEW, "
            f"or upgrade it first: openral-data upgrade {old} NEW"
        )
    numbers = _numbers(old) if takes.episodes else []
    for name, syntax in takes.episodes:
        if kwargs.get(name) is not None:
            kwargs[name] = _renumbered(syntax, kwargs[name], numbers)
    from openral_data.upgrade import upgrade

    with tempfile.TemporaryDirectory(prefix="openral-upgrade-") as tmp:
        swapped: list[Any] = []
        for i, (item, version) in enumerate(zip(items, versions, strict=True)):
            if version is None:
                swapped.append(item)
                continue
            if not terminal.quiet and terminal.err_console.is_terminal:  # like a progress bar: people, not logs
                terminal.print_line(
                    f"{item}: LeRobot {version}, read through a temporary v3.0 upgrade "
                    f"(`openral-data upgrade {item} NEW` keeps one)",
                    err=True,
                )
            root = resolve_dataset(item)  # the copy keeps its folder name: a label shown (quality, replay)
            swapped.append(upgrade(root, Path(tmp) / str(i) / root.name).out)
        kwargs[takes.param] = swapped if isinstance(given, list | tuple) else swapped[0]
        made = {
            str(Path(new).resolve()): Upgraded(str(item), tuple(_numbers(item)))
            for item, new in zip(items, swapped, strict=True)
            if new is not item
        }
        token = _UPGRADED.set(made)
        try:
            with _as_given({str(new): str(item) for item, new in zip(items, swapped, strict=True)}, old, numbers):
                yield
        finally:
            _UPGRADED.reset(token)


def _legacy(item: Any) -> str | None:
    """ "v2.0"/"v2.1" when `item` names a LeRobot v2.x dataset; None otherwise (what else is wrong with it is the
    command's to say, in its own words)."""
    from openral_data.formats.dataset import open_lerobot

    try:
        return open_lerobot(resolve_dataset(item)).legacy
    except (OpenralError, OSError, ValueError):
        return None


def _numbers(item: Any) -> list[int]:
    """The v2.x dataset's own episode numbers, in the order its upgrade numbers them 0..n-1."""
    from openral_data.upgrade.legacy import read_legacy

    return read_legacy(resolve_dataset(item)).numbers


def _renumbered(syntax: Numbers, text: str, numbers: Sequence[int]) -> str:
    """`text`, typed in the v2.x dataset's episode `numbers`, in its upgrade's numbering."""
    if syntax == "frames":
        from openral_data.edit.trim import renumber_frames

        return renumber_frames(text, numbers)
    if syntax == "spec":
        from openral_data.edit.splits import renumber_spec

        return renumber_spec(text, numbers)
    from openral_data.episodes import renumber_list

    return renumber_list(text, numbers)


@contextmanager
def _as_given(swapped: dict[str, str], old: Any, numbers: Sequence[int]) -> Iterator[None]:
    """An error of the command names the datasets as the user gave them, not their temporary upgrades; an episode
    it names is the upgrade's, so the message says how OLD's are numbered there."""
    try:
        yield
    except OpenralError as exc:
        message = str(exc)
        for upgraded, item in swapped.items():
            message = message.replace(upgraded, item)
        if isinstance(exc, EpisodeSelectionError) and list(numbers) != list(range(len(numbers))):
            from openral_data.episodes import format_episodes

            message += (
                f" (the temporary v3.0 upgrade numbers {old}'s episodes {format_episodes(list(numbers))} "
                f"as 0..{len(numbers) - 1})"
            )
        if message == str(exc):
            raise
        raise exc.amended(message) from exc
