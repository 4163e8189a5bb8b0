"""The repository root and the isolated project home every test that needs one records into."""

from __future__ import annotations

import os
import shutil
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent.parent
BUILTIN = REPO / "openral_data" / "builtin"  # the manifests the package ships


@contextmanager
def isolated_home(base: Path) -> Iterator[Path]:
    """`base/project`: a copy of the package's built-in manifests (robots/, rskills/, scenes/) and an empty
    datasets/, set as OPENRAL_DATA_HOME for the duration (made once; entering again reuses it), so tests can add
    broken files."""
    home = base / "project"
    if not home.exists():
        for sub in ("robots", "rskills", "scenes"):
            shutil.copytree(BUILTIN / sub, home / sub)
        (home / "datasets").mkdir()
    old = os.environ.get("OPENRAL_DATA_HOME")
    os.environ["OPENRAL_DATA_HOME"] = str(home)
    try:
        yield home
    finally:
        if old is None:
            os.environ.pop("OPENRAL_DATA_HOME", None)
        else:
            os.environ["OPENRAL_DATA_HOME"] = old
