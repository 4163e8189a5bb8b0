"""A normal install records: the wheel built from pyproject.toml, installed with the locked dependencies into a
fresh virtual environment outside the repository, run from an empty folder (no checkout, no OPENRAL_DATA_HOME),
finds its built-in scenes, rSkills and robots and records into ./datasets there."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from openral_data.version import __version__
from tests.support.home import REPO
from tests.support.wheel import run_installed

pytestmark = [pytest.mark.slow, pytest.mark.xdist_group("wheel")]


@pytest.fixture
def venv(core_venv: Path) -> Path:
    """A fresh environment holding the wheel and the lock's core dependencies (no dev group, no extras)."""
    return core_venv


def test_the_wheel_holds_the_package_only(venv: Path) -> None:
    site = next((venv / "lib").glob("python3.12/site-packages"))
    assert (site / "openral_data/builtin/scenes/sim/tabletop_push.yaml").is_file()
    assert (site / "openral_data/py.typed").is_file()
    assert (site / "openral_data/browse/static/episode.js").is_file()  # browse's pages ship as package data
    (record,) = site.glob("openral_data-*.dist-info/RECORD")
    tops = {line.split("/", 1)[0] for line in record.read_text().splitlines() if "/" in line.split(",", 1)[0]}
    # no `tests` package (or anything else) beside ours; `..` is the bin/openral-data script
    assert tops == {"openral_data", record.parent.name, ".."}


def test_installed_lists_its_builtins_and_records_into_cwd(venv: Path, tmp_path: Path) -> None:
    work = tmp_path / "empty"
    work.mkdir()
    version = run_installed(venv, work, "--version")
    assert version.returncode == 0 and version.stdout.strip() == f"openral-data {__version__}"

    listed = run_installed(venv, work, "list", "--json")
    assert listed.returncode == 0, listed.stderr
    doc = json.loads(listed.stdout)
    site = str(next((venv / "lib").glob("python3.12/site-packages")))
    for section, expected in (
        ("scenes", {"mock_pick", "tabletop_push", "robosuite_lift"}),
        ("rskills", {"random-mock", "scripted-push"}),
        ("robots", {"mock_arm", "franka_panda"}),
    ):
        items = {it["id"]: it for it in doc[section]}
        assert expected <= set(items), section
        assert all(it["origin"] == "built-in" and it["path"].startswith(site) for it in items.values())
        assert all(it["error"] is None for it in items.values()), section
    assert doc["plugin_problems"] == []

    for scene in ("mock_pick", "tabletop_push"):
        done = run_installed(venv, work, "record", "--scene", scene, "--n-episodes", "1", "--json")
        assert done.returncode == 0, done.stderr
        out = Path(json.loads(done.stdout)["out"])
        assert out.parent == work / "datasets" and out.name == f"{scene}-1", out
        # lerobot is not in the core install: the test environment's (dev group) loads what it wrote
        loaded = subprocess.run(
            [sys.executable, "-c", _LOAD, str(out)], capture_output=True, text=True, timeout=600, check=False
        )
        assert loaded.returncode == 0, loaded.stderr
        assert "torchcodec" not in loaded.stdout + loaded.stderr  # the lock leaves it out; pyav is chosen
        assert json.loads(loaded.stdout.splitlines()[-1]) == {"episodes": 1, "robot_type": _ROBOT[scene]}
    assert not (REPO / "datasets" / out.name).exists()


_ROBOT = {"mock_pick": "mock_arm", "tabletop_push": "franka_panda"}
_LOAD = """
import json, sys
from lerobot.datasets.lerobot_dataset import LeRobotDataset
ds = LeRobotDataset("local/installed", root=sys.argv[1], video_backend="pyav")
ds[0]
print(json.dumps({"episodes": ds.meta.total_episodes, "robot_type": ds.meta.robot_type}))
"""


def test_browse_without_its_extra_says_which_in_one_line(venv: Path, tmp_path: Path) -> None:
    r = run_installed(venv, tmp_path, "browse", str(tmp_path))
    assert r.returncode == 2
    assert r.stderr.count("\n") == 1 and "'browse' extra" in r.stderr and "uv sync --extra browse" in r.stderr
