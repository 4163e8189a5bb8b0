"""A lean core: `pip install openral-data` (the wheel with the lock's core dependencies, no extras) has no
lerobot, torch or CUDA, ships the example pipelines, and in an empty folder records the real-physics
`tabletop_push` (lerobot and MCAP at once), converts a bag back, edits, checks, measures and views the result.
What needs lerobot says which extra to install, both ways, in one line. Its size is stated in docs/install.md.
No stray outputs: `view` (no display) and `replay` without an output option write under the project's datasets/
and results/, never into the current folder."""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

import pytest

from tests.support.home import REPO, isolated_home
from tests.support.inproc import run_inproc
from tests.support.recorded import record_small
from tests.support.wheel import run_installed, site_packages, venv_bytes

# the tests on the installed wheel: slow, and in one xdist group, so one worker builds the venv for them all
WHEEL = pytest.mark.xdist_group("wheel")

# torch and its CUDA libraries alone were 4.5 GB; the core measured 2.2 GB (docs/install.md): room for drift, none
# for torch coming back
MAX_BYTES = 2.6e9


@pytest.mark.slow
@WHEEL
def test_the_core_has_no_torch_and_ships_the_pipelines(core_venv: Path) -> None:
    site = site_packages(core_venv)
    found = subprocess.run(
        [
            str(core_venv / "bin/python"),
            "-c",
            "import importlib.util as u; print([m for m in "
            "('torch', 'lerobot', 'triton', 'torchvision', 'nvidia') if u.find_spec(m)])",
        ],
        capture_output=True,
        text=True,
        timeout=120,
        check=True,
    )
    assert found.stdout.strip() == "[]"
    assert not list(site.glob("nvidia*")) and not list(site.glob("torch*"))
    assert (site / "openral_data/builtin/pipelines/mock_campaign.yaml").is_file()
    assert (site / "openral_data/builtin/pipelines/tabletop_push_campaign.yaml").is_file()
    assert venv_bytes(core_venv) < MAX_BYTES


def _ok(venv: Path, cwd: Path, *args: str) -> str:
    done = run_installed(venv, cwd, *args)
    assert done.returncode == 0, f"{args}: {done.stderr}"
    return done.stdout


@pytest.mark.slow
@WHEEL
def test_the_core_records_converts_edits_checks_measures_and_views(core_venv: Path, tmp_path: Path) -> None:
    work = tmp_path / "empty"
    work.mkdir()
    rec = ["record", "--scene", "tabletop_push", "--n-episodes", "2", "--max-steps", "6", "--codec", "h264"]
    _ok(core_venv, work, *rec, "--format", "lerobot,mcap", "--out", "datasets/push")
    _ok(core_venv, work, "convert", "datasets/push/mcap", "datasets/from-bags", "--codec", "h264")
    _ok(core_venv, work, "episodes", "delete", "datasets/from-bags", "--episodes", "1", "--out", "datasets/one")
    assert "healthy" in _ok(core_venv, work, "doctor", "datasets/one")
    stats = json.loads(_ok(core_venv, work, "stats", "datasets/push", "datasets/one", "--format", "json"))
    assert {g["dataset"]: g["episodes"] for g in stats["groups"]} == {"push": 2, "one": 1}
    assert json.loads(_ok(core_venv, work, "info", "datasets/one", "--json"))["episodes"] == 1
    # no display here: `view` saves the episode, by default beside the outputs under datasets/, not in the cwd
    _ok(core_venv, work, "view", "datasets/one", "--save", "datasets/one.rrd")
    _ok(core_venv, work, "view", "datasets/push", "--episode", "1")
    assert (work / "datasets/one.rrd").stat().st_size > 0
    assert (work / "datasets/push-episode-1.rrd").stat().st_size > 0
    assert not list(work.glob("*.rrd"))


@pytest.mark.slow
@WHEEL
def test_what_needs_lerobot_names_its_extra_both_ways(core_venv: Path, tmp_path: Path) -> None:
    done = run_installed(core_venv, tmp_path, "record", "--scene", "mock_pick", "--device", "cpu", "--n-episodes", "1")
    assert done.returncode == 2
    assert done.stderr.count("\n") == 1, done.stderr
    assert "'lerobot' extra" in done.stderr
    assert "pip install 'openral-data[lerobot]'" in done.stderr and "uv sync --extra lerobot" in done.stderr


def test_view_and_replay_write_under_the_project_not_the_cwd(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    ds = record_small(tmp_path)
    cwd = tmp_path / "elsewhere"
    cwd.mkdir()
    monkeypatch.chdir(cwd)
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    with isolated_home(tmp_path) as home:
        viewed = run_inproc("view", str(ds), "--episode", "1")
        replayed = run_inproc("replay", str(ds), "--json")
    assert viewed.returncode == 0, viewed.stderr
    assert (home / "datasets" / "ds-episode-1.rrd").stat().st_size > 0
    assert replayed.returncode == 0, replayed.stderr
    (results,) = (home / "results").iterdir()
    assert results.name == "ds-replay-actions-1" and (results / "summary.json").is_file()
    assert json.loads(replayed.stdout)["results"] == str(results)
    assert list(cwd.iterdir()) == []


def test_the_default_outputs_are_git_ignored_here() -> None:
    names = ["datasets/a/meta/info.json", "datasets/a-episode-0.rrd", "results/r/summary.json", "runs/p/x/.done.json"]
    done = subprocess.run(["git", "check-ignore", *names], cwd=REPO, capture_output=True, text=True, check=False)
    assert done.stdout.split() == names, done.stderr


def test_the_so_arm_driver_error_names_its_extra(
    project: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import lerobot.robots

    def no_sdk(config: object) -> None:  # what lerobot raises without the feetech extra's SDK
        raise ImportError("'feetech-servo-sdk' is required but not installed: pip install 'lerobot[feetech]'")

    monkeypatch.setattr(lerobot.robots, "make_robot_from_config", no_sdk)
    argv = ["record", "--hal", "so100_follower", "--mode", "real", "--rskill", "sweep-so-arm", "--fps", "10"]
    done = run_inproc(*argv, "--port", "/dev/null", "--out", str(tmp_path / "out"))
    assert done.returncode == 2, done.stderr
    assert "needs the 'feetech' extra" in done.stderr and "so_follower" not in done.stderr
    assert "pip install 'openral-data[feetech]'" in done.stderr and "uv sync --extra feetech" in done.stderr
    assert not (tmp_path / "out").exists()


def test_hardware_without_lerobot_names_the_lerobot_extra(
    project: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import sys

    from openral_data.producers.hal.robots.lerobot_hw import registry

    monkeypatch.setitem(sys.modules, "lerobot.robots", None)  # as in the core install: no lerobot
    registry.cache_clear()
    try:
        argv = ["record", "--hal", "so100_follower", "--mode", "real", "--rskill", "sweep-so-arm", "--fps", "10"]
        done = run_inproc(*argv, "--port", "/dev/null", "--out", str(tmp_path / "out"))
    finally:
        registry.cache_clear()
    assert done.returncode == 2, done.stderr
    assert "need the 'lerobot' extra" in done.stderr and "uv sync --extra lerobot" in done.stderr
    assert not (tmp_path / "out").exists()
