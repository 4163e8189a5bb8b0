"""The manifest search path: built-in < user config home < project < --*-dir / $OPENRAL_*_DIR, overrides named,
outputs under the project directory (the current one unless $OPENRAL_DATA_HOME)."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from openral_data import manifests
from openral_data.runtime import registry
from tests.support.cli import run_cli
from tests.support.home import BUILTIN, REPO
from tests.support.scenes import mock_scene, write_yaml

ENV = ("OPENRAL_DATA_HOME", "OPENRAL_DATA_CONFIG", *manifests.ENV_DIRS.values())


@pytest.fixture
def clean(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> Path:
    """No manifest folders but the built-ins: an empty current directory and config home."""
    for name in ENV:
        monkeypatch.delenv(name, raising=False)
    monkeypatch.setenv("XDG_CONFIG_HOME", str(tmp_path / "config"))
    cwd = tmp_path / "cwd"
    cwd.mkdir()
    monkeypatch.chdir(cwd)
    return cwd


def _rskill(folder: Path, ident: str = "random-mock") -> Path:
    dest = folder / "rskills" / ident
    shutil.copytree(BUILTIN / "rskills/random-mock", dest)
    return dest / "rskill.yaml"


def test_builtins_only(clean: Path) -> None:
    entries = manifests.entries("robots")
    assert "franka_panda" in entries and all(e.origin == "built-in" and not e.overrides for e in entries.values())
    assert manifests.find("scenes", "tabletop_push") == BUILTIN / "scenes/sim/tabletop_push.yaml"
    assert manifests.find("scenes", "nope") is None
    assert manifests.datasets_dir() == clean / "datasets" and manifests.project_dir() == clean


def test_each_layer_overrides_the_ones_below(clean: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    user = _rskill(tmp_path / "config/openral-data")
    assert manifests.entries("rskills")["random-mock"] == manifests.Entry(
        "rskills", "random-mock", user, "user", ("built-in",)
    )
    project = _rskill(clean)
    entry = manifests.entries("rskills")["random-mock"]
    assert (entry.path, entry.origin, entry.overrides) == (project, "project", ("built-in", "user"))
    extra = _rskill(tmp_path / "extra")
    monkeypatch.setenv("OPENRAL_RSKILLS_DIR", str(tmp_path / "nowhere") + os.pathsep + str(tmp_path / "extra/rskills"))
    entry = manifests.entries("rskills")["random-mock"]
    assert (entry.path, entry.origin) == (extra, "$OPENRAL_RSKILLS_DIR")
    assert entry.overrides == ("built-in", "user", "project")
    assert registry.resolve_rskill("random-mock")[1] == extra
    # $OPENRAL_DATA_HOME replaces the current directory as the project (manifests and outputs)
    home = tmp_path / "home"
    _rskill(home, "only-in-home")
    monkeypatch.setenv("OPENRAL_DATA_HOME", str(home))
    assert "only-in-home" in manifests.ids("rskills") and manifests.datasets_dir() == home / "datasets"
    assert manifests.entries("rskills")["random-mock"].overrides == ("built-in", "user")  # cwd's is no layer now


def test_scenes_flat_or_by_tier(clean: Path) -> None:
    write_yaml(clean / "scenes/mine.yaml", mock_scene(scene_id="mine"))
    write_yaml(clean / "scenes/sim/mock_pick.yaml", mock_scene(scene_id="mock_pick"))
    entries = manifests.entries("scenes")
    assert entries["mine"].path == clean / "scenes/mine.yaml" and entries["mine"].origin == "project"
    assert entries["mock_pick"].overrides == ("built-in",)
    assert registry.resolve_scene_path("mine") == clean / "scenes/mine.yaml"


def test_cli_dir_options_and_default_output(tmp_path: Path) -> None:
    extra = tmp_path / "extra"
    write_yaml(extra / "sim/tiny.yaml", mock_scene(scene_id="tiny", n_episodes=1, max_steps=3))
    cwd = tmp_path / "work"
    cwd.mkdir()
    env = {name: "" for name in ENV} | {"XDG_CONFIG_HOME": str(tmp_path / "config"), "PYTHONPATH": str(REPO)}
    done = subprocess.run(
        [sys.executable, "-m", "openral_data.cli", "--scenes-dir", str(extra), "record", "--scene", "tiny"],
        cwd=cwd,
        env={**os.environ, **env},
        capture_output=True,
        text=True,
        timeout=600,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    (out,) = (cwd / "datasets").iterdir()  # no --out: ./datasets of the current directory
    assert out.name == "tiny-1" and (out / "meta/info.json").is_file()

    missing = run_cli("--robots-dir", str(tmp_path / "nope"), "list")
    assert missing.returncode == 2 and missing.stdout == ""
    assert missing.stderr.strip() == f"error: --robots-dir: {tmp_path / 'nope'} is not a folder"
