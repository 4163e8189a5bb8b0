"""Shared fixtures: an isolated project root (robots/, rskills/, scenes/), offline HF caches, helpers."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
import yaml

REPO = Path(__file__).resolve().parent.parent


@pytest.fixture(autouse=True, scope="session")
def _offline_hf(tmp_path_factory: pytest.TempPathFactory) -> Iterator[None]:
    """lerobot's loader must never reach for the Hub, and its Arrow cache must not leak into ~/.cache."""
    hf = tmp_path_factory.mktemp("hf_home")
    old = {k: os.environ.get(k) for k in ("HF_HOME", "HF_HUB_OFFLINE", "HF_DATASETS_OFFLINE")}
    os.environ.update({"HF_HOME": str(hf), "HF_HUB_OFFLINE": "1", "HF_DATASETS_OFFLINE": "1"})
    yield
    for k, v in old.items():
        if v is None:
            os.environ.pop(k, None)
        else:
            os.environ[k] = v


@pytest.fixture
def project(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """A copy of the repo's manifests in tmp, used as OPENRAL_DATA_HOME, so tests can add broken files."""
    root = tmp_path / "project"
    for sub in ("robots", "rskills", "scenes"):
        shutil.copytree(REPO / sub, root / sub)
    (root / "datasets").mkdir()
    monkeypatch.setenv("OPENRAL_DATA_HOME", str(root))
    return root


def write_yaml(path: Path, data: Any) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path


def mock_scene(
    *,
    scene_id: str = "mock_test",
    cameras: list[tuple[str, int, int]] | None = None,
    success_after: int | list[int] = 5,
    max_steps: int = 50,
    n_episodes: int = 3,
    fps: int = 20,
    **params: Any,
) -> dict[str, Any]:
    cams = cameras if cameras is not None else [("front", 64, 48), ("wrist", 32, 32)]
    return {
        "tier": "sim",
        "scene": {
            "id": scene_id,
            "type": "mock",
            "robot": "mock_arm",
            "fps": fps,
            "cameras": [{"name": n, "width": w, "height": h} for n, w, h in cams],
            "params": {"success_after": success_after, **params},
        },
        "task": {"scene_id": scene_id, "instruction": "pick up the mock cube", "max_steps": max_steps},
        "seed": 0,
        "n_episodes": n_episodes,
    }


def run_cli(*args: str, env: dict[str, str] | None = None) -> subprocess.CompletedProcess[str]:
    """Run the real `openral-data` entry point in a subprocess."""
    full_env = {**os.environ, **(env or {})}
    return subprocess.run(
        [sys.executable, "-m", "openral_data.cli", *args],
        capture_output=True,
        text=True,
        env=full_env,
        timeout=600,
        check=False,
    )
