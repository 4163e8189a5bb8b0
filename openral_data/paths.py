"""Where the project's manifests live: `robots/`, `rskills/`, `scenes/`, and the default `datasets/` root."""

from __future__ import annotations

import os
from pathlib import Path


def project_root() -> Path:
    """`$OPENRAL_DATA_HOME` if set, else the checkout this package was installed from (editable install)."""
    env = os.environ.get("OPENRAL_DATA_HOME")
    if env:
        return Path(env).expanduser().resolve()
    return Path(__file__).resolve().parent.parent


def robots_dir() -> Path:
    return project_root() / "robots"


def rskills_dir() -> Path:
    return project_root() / "rskills"


def scenes_dir() -> Path:
    return project_root() / "scenes"


def datasets_dir() -> Path:
    return project_root() / "datasets"


DEFAULT_SCENE = "mock_pick"
