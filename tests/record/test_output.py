"""One writer, decided before any byte: `record --out D` takes D's lock before it builds the scene and before it
writes anything; a second writer exits 2 naming the holder and changes nothing; an existing dataset is refused
without being touched; a read-only place gives one line. The real CLI, the mock scene."""

from __future__ import annotations

import json
import signal
import subprocess
import sys
import time
from pathlib import Path

import pyarrow.parquet as pq
import pytest

from openral_data.formats.lerobot_v3 import layout
from tests.support.cli import run_cli
from tests.support.interrupt import snapshot
from tests.support.lerobot import verify_mock_dataset
from tests.support.readonly import read_only_view
from tests.support.scenes import mock_scene, write_yaml
from tests.support.timing import TIMED

pytestmark = TIMED


def _wait_for_lock(proc: subprocess.Popen[str], out: Path) -> None:
    lock = out / layout.LOCK_PATH
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline:
        assert proc.poll() is None, proc.communicate()
        try:
            if lock.read_text().startswith(f"pid {proc.pid},"):
                return
        except OSError:
            pass
        time.sleep(0.005)
    raise AssertionError("the first writer never took the lock")


def _seeds(out: Path) -> list[int]:
    table = pq.read_table(sorted((out / "meta" / "episodes").rglob("*.parquet")))
    rows = sorted(table.to_pylist(), key=lambda r: int(r["episode_index"]))
    return [int(r["openral.seed"]) for r in rows]


@pytest.mark.slow
@pytest.mark.parametrize("workers", [1, 2])
def test_second_writer_started_while_the_first_builds_exits_2_and_changes_nothing(
    tmp_path: Path, project: Path, workers: int
) -> None:
    scene = write_yaml(tmp_path / "scene.yaml", mock_scene(success_after=[4, 6, 5], n_episodes=3))
    out = tmp_path / "ds"
    common = ["record", "--scene", str(scene), "--out", str(out), "--n-episodes", "3", "--codec", "h264"]
    cmd = [sys.executable, "-m", "openral_data.cli", *common, "--seed", "100", "--workers", str(workers)]
    first = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        _wait_for_lock(first, out)
        first.send_signal(signal.SIGSTOP)  # held between taking the lock and finishing: the race window, fixed
        before = snapshot(out)
        second = run_cli(*common, "--seed", "7", "--workers", str(workers))
        assert second.returncode == 2, second.stderr
        line = second.stderr.strip().splitlines()
        assert len(line) == 1 and line[0].startswith("error: "), second.stderr
        assert f"pid {first.pid}," in line[0] and "another writer holds this dataset" in line[0]
        assert snapshot(out) == before  # the loser changed nothing
    finally:
        first.send_signal(signal.SIGCONT)
    _, err = first.communicate(timeout=300)
    assert first.returncode == 0, err
    settings = json.loads((out / layout.RECORD_PATH).read_text())
    assert settings["options"]["seed"] == 100
    if workers == 1:
        verify_mock_dataset(out)
    else:  # the workers' shares number their mock episodes per worker; lerobot still loads the merged dataset
        from lerobot.datasets.lerobot_dataset import LeRobotDataset

        ds = LeRobotDataset("local/check", root=out, video_backend="pyav")
        assert len(ds) == ds.meta.total_frames > 0 and ds.meta.total_episodes == 3
    assert _seeds(out) == [100, 101, 102]
    assert not (out / layout.LOCK_PATH).exists()
    if workers == 1:  # the first's --resume continues with its own seeds
        resumed = run_cli("record", "--resume", "--out", str(out), "--n-episodes", "5", "--scene", str(scene))
        assert resumed.returncode == 0, resumed.stderr
        verify_mock_dataset(out)
        assert _seeds(out) == [100, 101, 102, 103, 104]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["ds", "project", "scene.yaml"]  # no hidden leftovers


@pytest.mark.parametrize("what", ["dataset", "settings only", "foreign file"])
def test_fresh_record_into_existing_output_is_refused_untouched(tmp_path: Path, project: Path, what: str) -> None:
    scene = write_yaml(tmp_path / "scene.yaml", mock_scene(success_after=3, n_episodes=1))
    out = tmp_path / "ds"
    args = ["record", "--scene", str(scene), "--out", str(out), "--codec", "h264"]
    if what == "dataset":
        assert run_cli(*args).returncode == 0
    elif what == "settings only":  # a run killed right after it stored its settings
        (out / ".openral").mkdir(parents=True)
        (out / layout.RECORD_PATH).write_text('{"options": {"seed": 5}, "schema": {}}')
    else:
        out.mkdir()
        (out / "notes.txt").write_text("mine")
    before = snapshot(out)
    stamps = {p: p.stat().st_mtime_ns for p in [out, *out.rglob("*")]}
    proc = run_cli(*args, "--seed", "9")
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"error: {out}: --out "), proc.stderr
    assert snapshot(out) == before
    assert {p: p.stat().st_mtime_ns for p in [out, *out.rglob("*")]} == stamps  # not even the lock was taken


def test_stale_lock_of_a_killed_first_run_does_not_block(tmp_path: Path, project: Path) -> None:
    """A folder holding only a dead writer's lock file (killed before it wrote anything) is free to record."""
    scene = write_yaml(tmp_path / "scene.yaml", mock_scene(success_after=3, n_episodes=1))
    out = tmp_path / "ds"
    (out / ".openral").mkdir(parents=True)
    (out / layout.LOCK_PATH).write_text("pid 999999, openral-data record, since 2026-01-01T00:00:00Z\n")
    proc = run_cli("record", "--scene", str(scene), "--out", str(out), "--codec", "h264")
    assert proc.returncode == 0, proc.stderr
    verify_mock_dataset(out)


def test_read_only_parent_and_dataset_give_one_line(tmp_path: Path, project: Path) -> None:
    scene = write_yaml(tmp_path / "scene.yaml", mock_scene(success_after=3, n_episodes=1))
    src = tmp_path / "src"
    assert run_cli("record", "--scene", str(scene), "--out", str(src / "ds"), "--codec", "h264").returncode == 0
    with read_only_view(src, tmp_path / "ro") as ro:
        before = snapshot(ro)
        cases = [
            ["record", "--scene", str(scene), "--out", str(ro / "new"), "--codec", "h264"],
            ["record", "--resume", "--out", str(ro / "ds"), "--n-episodes", "2", "--scene", str(scene)],
        ]
        for args in cases:
            proc = run_cli(*args)
            assert proc.returncode == 2, proc.stderr
            lines = proc.stderr.strip().splitlines()
            assert len(lines) == 1 and lines[0].startswith("error: "), proc.stderr
            assert "Read-only file system" in lines[0]  # the wording is the point: it names the cause
        assert snapshot(ro) == before
