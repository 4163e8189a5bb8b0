"""The four third-party LeRobot datasets of tests/fixtures/lerobot/README.md: each is what the page says (files,
version, episodes, frames, cameras, its README.md and LICENSE), and every command that reads datasets takes it:
`info`, `doctor`, `stats`, `tasks list`, `view --save`, `convert` to MCAP, `upgrade` (v2.1) and an edit
(`tasks rename`). A command that refuses one does so by design and in one line naming the file and field: the
rerun apple fixture is a partial download (its mp4 absent, info.json's totals those of the full dataset), which
`info` and `tasks list` refuse (`total_frames`), and `view` / `convert` refuse naming the missing video.
Skipped only when the bytes are not beside the checkout (`../shared/fixtures/lerobot/`, `OPENRAL_REAL_LEROBOT`)."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pyarrow.parquet as pq
import pytest

from tests.support.inproc import Run, run_inproc
from tests.support.real_datasets import REAL, real_root

APPLE = "v30early_apple_storage_no_video"
# (fixture, command) -> what its one-line refusal names; every other pair must succeed
REFUSED = {
    (APPLE, "info"): "total_frames: 14983, but the episodes' lengths add up to 899",
    (APPLE, "tasks list"): "total_frames: 14983, but the episodes' lengths add up to 899",
    (APPLE, "view"): "file-000.mp4: observation.image: missing, not downloaded",
    (APPLE, "convert"): "file-000.mp4: observation.image: missing, not downloaded",
    (APPLE, "tasks rename"): "or drop that camera first: features remove",
}


@pytest.fixture(scope="module", params=sorted(REAL))
def real(request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory) -> tuple[str, Path]:
    """A fixture's name and a copy of it (commands never write into the fixtures)."""
    name = str(request.param)
    src = real_root(name)
    if src is None:
        pytest.skip(f"real fixture {name} not present (tests/fixtures/lerobot/README.md)")
    dest = tmp_path_factory.mktemp("real") / name
    shutil.copytree(src, dest)
    return name, dest


def _accepted(name: str, command: str, run: Run) -> bool:
    """Whether `run` succeeded; a refusal listed in `REFUSED` is checked to be that one line (and False)."""
    assert "Traceback" not in run.stderr, run.stderr
    refusal = REFUSED.get((name, command))
    if refusal is None:
        assert run.returncode == 0, f"{command}: {run.stderr}"
        return True
    assert run.returncode == 2 and refusal in run.stderr, run.stderr
    assert len(run.stderr.strip().splitlines()) == 1 and run.stderr.startswith("error: "), run.stderr
    return False


def _data_rows(root: Path) -> int:
    return sum(pq.read_metadata(p).num_rows for p in root.glob("data/*/*.parquet"))


def _first_episode(root: Path) -> int:
    """The first episode's number as the dataset has it (the G1 fixture's only episode is 29)."""
    lines = root / "meta/episodes.jsonl"
    return int(json.loads(lines.read_text().splitlines()[0])["episode_index"]) if lines.is_file() else 0


def test_each_is_what_the_readme_says(real: tuple[str, Path]) -> None:
    name, root = real
    want = REAL[name]
    info = json.loads((root / "meta/info.json").read_text())
    assert info["codebase_version"] == want.version
    assert all((root / f).is_file() for f in want.files), [f for f in want.files if not (root / f).is_file()]
    assert (root / "README.md").is_file() and (root / "LICENSE").is_file()
    assert (
        want.license in (root / "README.md").read_text()
        or want.license.split("-")[0] in (root / "README.md").read_text()
    )
    cameras = tuple(k for k, ft in info["features"].items() if ft["dtype"] in ("image", "video"))
    assert cameras == want.cameras
    assert _data_rows(root) == want.frames


def test_info_tasks_stats_and_doctor_read_it(real: tuple[str, Path]) -> None:
    name, root = real
    want = REAL[name]
    info = run_inproc("info", str(root), "--json")
    if _accepted(name, "info", info):
        doc = json.loads(info.stdout)
        assert (doc["episodes"], doc["frames"], doc["cameras"]) == (want.episodes, want.frames, list(want.cameras))
    tasks = run_inproc("tasks", "list", str(root))
    if _accepted(name, "tasks list", tasks):
        assert "episodes" in tasks.stdout
    stats = run_inproc("stats", str(root), "--json")
    _accepted(name, "stats", stats)
    assert json.loads(stats.stdout)["groups"][0]["frames"] == want.frames
    doctor = run_inproc("doctor", str(root), "--json")  # findings are fine (exit 1): the dataset is theirs
    assert doctor.returncode in (0, 1) and "Traceback" not in doctor.stderr, doctor.stderr
    assert json.loads(doctor.stdout)["errors"] >= 0


def test_view_and_convert_to_mcap(real: tuple[str, Path], tmp_path: Path) -> None:
    name, root = real
    rrd = tmp_path / "episode.rrd"
    view = run_inproc("view", str(root), "--episode", str(_first_episode(root)), "--save", str(rrd))
    if _accepted(name, "view", view):
        assert rrd.stat().st_size > 0
    out = tmp_path / "mcap"
    convert = run_inproc("convert", str(root), str(out))
    if _accepted(name, "convert", convert):
        assert len(list(out.rglob("*.mcap"))) == REAL[name].episodes
    else:
        assert not out.exists()


@pytest.mark.slow  # a v2.1 fixture goes through the temporary upgrade (its video's statistics computed)
def test_an_edit_and_the_upgrade(real: tuple[str, Path], tmp_path: Path) -> None:
    """`tasks rename` writes a new dataset whose only task is renamed (a v2.1 one through the temporary
    upgrade); a v2.1 fixture upgrades to a v3.0 dataset `doctor --deep` finds healthy."""
    name, root = real
    old = _only_task(root)
    edited = tmp_path / "renamed"
    res = run_inproc("tasks", "rename", "--from", old, "--to", "renamed task", "--out", str(edited), str(root))
    if not _accepted(name, "tasks rename", res):  # the apple's missing video: dropped first, as the line says
        dropped = tmp_path / "dropped"
        res = run_inproc("features", "remove", str(root), "--feature", REAL[name].cameras[0], "--out", str(dropped))
        assert res.returncode == 0, res.stderr
        args = ("tasks", "rename", "--from", old, "--to", "renamed task", "--out", str(edited), str(dropped))
        assert run_inproc(*args).returncode == 0
        assert run_inproc("info", str(edited)).returncode == 0  # its totals counted again by the edit
    assert _only_task(edited) == "renamed task" and _data_rows(edited) == REAL[name].frames
    if REAL[name].version != "v2.1":
        return
    new = tmp_path / "upgraded"
    assert run_inproc("upgrade", str(root), str(new)).returncode == 0
    doctor = run_inproc("doctor", "--deep", str(new), "--json")
    assert doctor.returncode == 0 and json.loads(doctor.stdout)["healthy"] is True, doctor.stdout


def _only_task(root: Path) -> str:
    """The dataset's first task text (tasks.jsonl, or tasks.parquet: its `task` column, or the index column of the
    early v3 writer)."""
    lines = root / "meta/tasks.jsonl"
    if lines.is_file():
        return str(json.loads(lines.read_text().splitlines()[0])["task"])
    table = pq.read_table(root / "meta/tasks.parquet")
    column = "task" if "task" in table.column_names else "__index_level_0__"
    return str(table.column(column)[0].as_py())
