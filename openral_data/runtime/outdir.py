"""Output folders of the commands that write something new (`record`, `record --hal`, `replay` and its
`--record`): the one fresh default name under datasets/ (replay's results under results/), and the refusal of an
`--out` that already holds something."""

from __future__ import annotations

from pathlib import Path

from openral_data import manifests, paths
from openral_data.errors import OutputExists


def fresh_out(prefix: str, under: Path | None = None) -> Path:
    """A folder under `under` (default datasets/) named `<prefix>-<n>` that does not exist yet: n the first free
    number from 1 (`datasets/mock_pick-1`, `datasets/mock_pick-2`, ...), a name short enough to read in a table."""
    folder = under or manifests.datasets_dir()
    n = 1
    while (folder / f"{prefix}-{n}").exists() or (folder / f"{prefix}-{n}").is_symlink():
        n += 1
    return folder / f"{prefix}-{n}"


def check_out(out: Path) -> None:
    """Refuse an `--out` that holds anything but (at most) a writer lock file: a recording starts a new folder."""
    paths.check_creatable(out, "--out")
    if out.is_symlink() or (out.exists() and not out.is_dir()):
        raise OutputExists(f"{out}: --out exists and is not a directory")
    if out.is_dir() and not all(_lock_only(p) for p in out.iterdir()):
        if (out / "meta" / "info.json").exists() or (out / ".openral" / "record.json").exists():
            raise OutputExists(
                f"{out}: --out already holds a dataset; refusing to overwrite it (choose a new --out, or --resume)"
            )
        raise OutputExists(f"{out}: --out exists, is not empty and is not a dataset; refusing to write there")


def _lock_only(entry: Path) -> bool:
    """`entry` is a real `.openral/` folder holding nothing but the writer lock (a live or a killed writer's)."""
    if entry.name != ".openral" or entry.is_symlink() or not entry.is_dir():
        return False
    return all(p.name == "lock" for p in entry.iterdir())
