"""A LeRobot v2.0/v2.1 dataset given to a command that needs v3 (every edit, `stats recompute`, `videos …`,
`replay`) is read through a temporary upgrade: `openral-data upgrade` (lerobot's own converter steps) writes it as
v3.0 into a temporary folder, the command runs on that, and the folder goes when the command ends. The source is
only read; `--in-place` on a v2.x dataset is refused (the edit writes v3.0, so it goes to `--out NEW`). The
read-only commands (`info`, `doctor`, `stats`, `view`, `tasks list`, `convert`) read v2.x in place
(`formats.dataset`) and are not listed here. docs/upgrade.md#other-commands-on-v2x-datasets.
"""

from __future__ import annotations

import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from openral_data.cli import terminal
from openral_data.errors import OpenralError, UsageError
from openral_data.formats.repo_id import resolve_dataset


@contextmanager
def read_as_v3(kwargs: dict[str, Any], param: str) -> Iterator[None]:
    """While the block runs, each v2.x dataset `kwargs[param]` names (one path or a list) is replaced by a
    temporary v3.0 upgrade of it; anything else (v3, a path that is not a dataset) is left to the command."""
    given = kwargs[param]
    items = list(given) if isinstance(given, list | tuple) else [given]
    versions = [_legacy(item) for item in items]
    if not any(versions):
        yield
        return
    if kwargs.get("in_place"):
        old = next(item for item, v in zip(items, versions, strict=True) if v)
        raise UsageError(
            f"{old}: a LeRobot {_legacy(old)} dataset is not edited in place (the edit writes v3.0): give --out NEW, "
            f"or upgrade it first: openral-data upgrade {old} NEW"
        )
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
            swapped.append(upgrade(resolve_dataset(item), Path(tmp) / str(i)).out)
        kwargs[param] = swapped if isinstance(given, list | tuple) else swapped[0]
        yield


def _legacy(item: Any) -> str | None:
    """ "v2.0"/"v2.1" when `item` names a LeRobot v2.x dataset; None otherwise (what else is wrong with it is the
    command's to say, in its own words)."""
    from openral_data.formats.dataset import open_lerobot

    try:
        return open_lerobot(resolve_dataset(item)).legacy
    except (OpenralError, OSError, ValueError):
        return None
