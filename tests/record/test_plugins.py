"""Plug-ins: two real packages (tests/plugins/) installed with uv into a folder of their own and put on the CLI's
PYTHONPATH. The demo plug-in's scene type, policy and manifests record a dataset lerobot loads; the broken one is
reported in one line per entry point and breaks nothing."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from openral_data import POLICIES, SCENES
from openral_data.policies.base import PolicyAdapter
from openral_data.policies.basic import ZeroPolicy
from openral_data.runtime import registry
from openral_data.schemas.rskill import RSkillManifest
from tests.cli.test_json import check_object
from tests.support.cli import run_cli
from tests.support.home import REPO
from tests.support.uv import uv

PLUGINS = REPO / "tests" / "plugins"
DEMO = "openral-demo-plugin"
BROKEN = "openral-broken-plugin"


@pytest.fixture(scope="module")
def site(tmp_path_factory: pytest.TempPathFactory) -> Path:
    target = tmp_path_factory.mktemp("plugins") / "site"
    install = ["pip", "install", "--quiet", "--no-deps", "--target", str(target), "--python", sys.executable]
    subprocess.run([uv(), *install, str(PLUGINS / "demo"), str(PLUGINS / "broken")], check=True, timeout=600)
    return target


def _env(site: Path, home: Path) -> dict[str, str]:
    return {"PYTHONPATH": os.pathsep.join([str(site), str(REPO)]), "OPENRAL_DATA_HOME": str(home)}


def test_list_shows_plugin_entries_and_reports_broken_ones(site: Path, tmp_path: Path) -> None:
    proc = run_cli("list", "--json", env=_env(site, tmp_path))
    assert proc.returncode == 0, proc.stderr
    doc = json.loads(proc.stdout)
    origin = f"plug-in {DEMO}"
    by = {
        name: {it["id"]: it for it in doc[name]} for name in ("scenes", "rskills", "robots", "scene_types", "policies")
    }
    assert by["scene_types"]["slider"]["origin"] == origin
    assert by["scenes"]["slider_reach"]["origin"] == origin and by["scenes"]["slider_reach"]["type"] == "slider"
    assert by["rskills"]["slider-p"]["origin"] == origin and by["rskills"]["slider-p"]["policy"] == "p_control"
    assert by["robots"]["slider"]["origin"] == origin and by["robots"]["slider"]["error"] is None
    assert by["policies"]["p_control"]["origin"] == "registered by openral_demo_plugin.policy"
    # the built-ins are all still there, and the clashing plug-in policy did not replace `random`
    assert by["policies"]["random"]["origin"] == "built-in" and by["scene_types"]["mock"]["origin"] == "built-in"
    assert {"mock_pick", "tabletop_push"} <= set(by["scenes"]) and "franka_panda" in by["robots"]
    problems = {(p["group"], p["name"]): p for p in doc["plugin_problems"]}
    assert set(problems) == {
        ("openral_data.scenes", "kaboom"),
        ("openral_data.robots", "broken_robots"),
        ("openral_data.policies", "random"),
    }
    assert all(p["dist"] == BROKEN for p in problems.values())
    for item in doc["plugin_problems"]:
        check_object(item, "list plugin_problems")
    check_object(by["scenes"]["slider_reach"], "list item", "list scenes")
    assert "vendor SDK" in problems[("openral_data.scenes", "kaboom")]["error"]
    assert "built in" in problems[("openral_data.policies", "random")]["error"]
    assert "is not a folder" in problems[("openral_data.robots", "broken_robots")]["error"]
    # one stderr line per broken entry point, and nothing else there
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 3 and all(line.startswith("warning: plug-in ") for line in lines)


def test_record_with_the_plugin_scene_and_policy(site: Path, tmp_path: Path) -> None:
    out = tmp_path / "slider"
    proc = run_cli(
        "record", "--scene", "slider_reach", "--n-episodes", "2", "--out", str(out), env=_env(site, tmp_path)
    )
    assert proc.returncode == 0, proc.stderr
    check = subprocess.run(
        [sys.executable, "-c", _LOAD, str(out)], capture_output=True, text=True, check=True, timeout=300
    )
    doc = json.loads(check.stdout.strip().splitlines()[-1])
    assert doc["episodes"] == 2 and doc["features"]["observation.images.rail"] == "video"
    assert doc["state_names"] == ["position", "velocity"] and doc["action_names"] == ["force"]
    assert doc["tasks"] == ["slide the mass to the green mark"]
    # the plug-in's physics ran: the PD controller brought the mass to its target and the episode succeeded
    last = np.array(doc["last_state"])
    assert abs(last[0] - 0.5) < 0.02 and doc["success"] == [True, True]


_LOAD = """
import json, sys
from lerobot.datasets.lerobot_dataset import LeRobotDataset
ds = LeRobotDataset("local/slider", root=sys.argv[1], video_backend="pyav")
ep0_end = int(ds.meta.episodes["dataset_to_index"][0]) - 1
print(json.dumps({
    "episodes": ds.meta.total_episodes,
    "features": {k: v["dtype"] for k, v in ds.meta.features.items()},
    "state_names": ds.meta.features["observation.state"]["names"],
    "action_names": ds.meta.features["action"]["names"],
    "tasks": list(ds.meta.tasks.index),
    "last_state": ds[ep0_end]["observation.state"].tolist(),
    "success": [bool(s) for s in ds.meta.episodes["openral.success"]],
}))
"""


def test_decorator_registers_into_the_registry() -> None:
    @POLICIES.register("test_zero_plugin")
    def factory(rskill: RSkillManifest) -> PolicyAdapter:
        return ZeroPolicy(rskill)

    assert POLICIES["test_zero_plugin"] is factory and "test_zero_plugin" in list(POLICIES)
    assert POLICIES.origin("test_zero_plugin") == f"registered by {__name__}"
    assert registry.POLICIES is POLICIES and registry.SCENES is SCENES
