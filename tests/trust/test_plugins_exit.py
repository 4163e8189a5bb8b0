"""#29 class 10: a plug-in that calls `sys.exit` while it is imported is a failing plug-in like any other: it is
reported in one warning line and left out, and `list` and `record` go on (before, the exit ended them)."""

from __future__ import annotations

import json
import os
from pathlib import Path

import pytest

from tests.support.cli import run_cli
from tests.support.home import REPO

DIST = "openral-exiting-plugin"


@pytest.fixture(scope="module")
def site(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A folder for PYTHONPATH holding an installed distribution (its dist-info) whose entry points' module
    exits at import."""
    site = tmp_path_factory.mktemp("exiting") / "site"
    info = site / "openral_exiting_plugin-0.1.dist-info"
    info.mkdir(parents=True)
    (site / "openral_exiting_plugin.py").write_text("import sys\n\nsys.exit(3)\n")
    (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {DIST}\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text(
        "[openral_data.scenes]\nexits = openral_exiting_plugin:make\n\n"
        "[openral_data.manifests]\nexits_too = openral_exiting_plugin\n"
    )
    return site


def _env(site: Path, home: Path) -> dict[str, str]:
    return {"PYTHONPATH": os.pathsep.join([str(site), str(REPO)]), "OPENRAL_DATA_HOME": str(home)}


def test_list_and_record_survive_a_plugin_that_exits(site: Path, tmp_path: Path) -> None:
    listed = run_cli("list", "--json", env=_env(site, tmp_path), timeout=120)
    assert listed.returncode == 0, listed.stderr
    problems = {(p["group"], p["name"]): p for p in json.loads(listed.stdout)["plugin_problems"]}
    assert set(problems) == {("openral_data.scenes", "exits"), ("openral_data.manifests", "exits_too")}
    assert all(p["dist"] == DIST and p["error"] == "SystemExit: 3" for p in problems.values())
    out = tmp_path / "ds"
    args = ["record", "--scene", "mock_pick", "--n-episodes", "1", "--max-steps", "2", "--codec", "h264"]
    recorded = run_cli(*args, "--out", str(out), env=_env(site, tmp_path), timeout=300)
    assert recorded.returncode == 0, recorded.stderr
    assert (out / "meta/info.json").is_file()
