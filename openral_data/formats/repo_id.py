"""A Hub `repo_id` (`lerobot/pusht`) given where a dataset folder is expected, resolved offline.

`resolve_dataset(arg)`: an argument that names an existing path is that path (a local folder named like a repo
id wins over the cache); one that does not but looks like `owner/name` is `HF_LEROBOT_HOME/owner/name`, exactly
where `LeRobotDataset(repo_id)` looks (lerobot 0.6.1's rule: `HF_LEROBOT_HOME`, else `$HF_HOME/lerobot`); when that
folder is missing too, one line says where it looked and that `--download` fetches it. Nothing here touches the
network: the CLI's `--download` (openral_data/cli/download.py, with `openral_data.hub.fetch_dataset`) fills the
cache folder before a command resolves its argument here.
"""

from __future__ import annotations

import os
import re
from pathlib import Path

from openral_data.errors import NotFound, UsageError

# Hub repo ids: one owner and one name of letters, digits, `-`, `_` and `.` (neither starting with `.` or `-`)
_REPO_ID = re.compile(r"[A-Za-z0-9_][A-Za-z0-9_.-]*/[A-Za-z0-9_][A-Za-z0-9_.-]*")
_GLOB = re.compile(r"[*?\[]")


def looks_like_repo_id(arg: str) -> bool:
    return _REPO_ID.fullmatch(arg) is not None and ".." not in arg


def lerobot_home() -> Path:
    """lerobot's cache folder, `HF_LEROBOT_HOME` (lerobot.utils.constants): the `HF_LEROBOT_HOME` variable, else
    `lerobot/` under huggingface_hub's `HF_HOME`, which lerobot reads too. Resolved without lerobot (not in the
    core install); the deprecated `LEROBOT_HOME` variable is refused, as lerobot refuses it."""
    if "LEROBOT_HOME" in os.environ:
        raise UsageError("LEROBOT_HOME: deprecated by lerobot; set HF_LEROBOT_HOME instead")
    from huggingface_hub.constants import HF_HOME

    return Path(os.environ.get("HF_LEROBOT_HOME", Path(HF_HOME) / "lerobot")).expanduser()


def resolve_dataset(arg: str | Path) -> Path:
    """The dataset folder `arg` names: an existing path as it is, else a repo id's folder in lerobot's cache."""
    path = Path(arg)
    text = str(arg)
    if path.exists() or path.is_symlink():
        return path
    if not looks_like_repo_id(text):
        if not _GLOB.search(text):  # `./x`, `/abs/x`, `x`: a path, never a Hub id (a glob is matched later)
            raise NotFound(f"{text}: no such file or directory")
        return path
    cached = lerobot_home() / text
    if not cached.is_dir() and path.parent.is_dir():  # `datasets/nope`: a local folder's missing child
        raise NotFound(
            f"{text}: no such folder (nor a Hub dataset of that id in the local cache: --download fetches one)"
        )
    if not cached.is_dir():
        raise NotFound(
            f"{text}: no such folder, and not in the local cache (looked in {cached}); add --download to fetch it "
            "from the Hub"
        )
    return cached
