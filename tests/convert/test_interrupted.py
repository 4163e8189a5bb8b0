"""A killed `convert` (bags -> LeRobot with several bags, LeRobot -> MCAP) leaves nothing under DST — no dataset
that loads, no bags — and the next run into the same parent is not refused, removes the dead run's staging
folder and finishes with no hidden leftovers. A Ctrl-C (one process or `--workers`) leaves nothing at all and
exits 130 with one line. A DST that cannot be written is one line, not a traceback."""

from __future__ import annotations

from pathlib import Path

import pytest

from openral_data.formats.mcap.writer import finished_bags
from tests.support.bags import MAPPING, write_ros1
from tests.support.cli import run_cli
from tests.support.interrupt import hidden_leftovers, interrupt_when, kill_when_staged, snapshot
from tests.support.readonly import read_only_view
from tests.support.scenes import write_yaml
from tests.support.timing import TIMED

pytestmark = [TIMED, pytest.mark.slow]
BAGS = 4


@pytest.fixture(scope="module")
def sources(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """A folder of several ROS 1 bags (one episode each) and its mapping."""
    root = tmp_path_factory.mktemp("bags")
    (root / "bags").mkdir()
    for i in range(BAGS):
        write_ros1(root / "bags" / f"run{i}.bag", duration_ms=4000, offset_ms=i * 60_000)
    return root / "bags", write_yaml(root / "mapping.yaml", MAPPING)


def _loads(root: Path) -> int:
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    return int(LeRobotDataset("local/check", root=root, video_backend="pyav").meta.total_episodes)


def test_killed_bags_to_lerobot_leaves_no_dataset_and_rerun_succeeds(
    tmp_path: Path, sources: tuple[Path, Path]
) -> None:
    bags, mapping = sources
    out = tmp_path / "ds"
    args = ["convert", str(bags), str(out), "--mapping", str(mapping), "--codec", "h264"]
    killed = kill_when_staged(args, out, "data/*/*.parquet")  # at least one episode committed
    assert not out.exists()
    assert hidden_leftovers(tmp_path) == [f".ds.partial-{killed.pid}", f".ds.partial-{killed.pid}.owner"]
    proc = run_cli(*args)
    assert proc.returncode == 0, proc.stderr
    assert _loads(out) == BAGS
    assert hidden_leftovers(tmp_path) == []


def test_killed_lerobot_to_mcap_leaves_no_bags_and_rerun_succeeds(tmp_path: Path, sources: tuple[Path, Path]) -> None:
    bags, mapping = sources
    dataset = tmp_path / "src"
    made = run_cli("convert", str(bags), str(dataset), "--mapping", str(mapping), "--codec", "h264")
    assert made.returncode == 0, made.stderr
    out = tmp_path / "bags_out"
    killed = kill_when_staged(["convert", str(dataset), str(out)], out, "episode_000000")  # the first bag finished
    assert not out.exists()
    assert f".bags_out.partial-{killed.pid}" in hidden_leftovers(tmp_path)
    proc = run_cli("convert", str(dataset), str(out))
    assert proc.returncode == 0, proc.stderr
    assert [b.name for b in finished_bags(out)] == [f"episode_{i:06d}" for i in range(BAGS)]
    assert hidden_leftovers(tmp_path) == []


@pytest.fixture(scope="module")
def long_sources(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """Four 20 s bags (200 frames each): a worker converting two of them is still at work when it is seen
    encoding its first one."""
    root = tmp_path_factory.mktemp("long")
    (root / "bags").mkdir()
    for i in range(BAGS):
        write_ros1(root / "bags" / f"run{i}.bag", duration_ms=20_000, offset_ms=i * 60_000)
    return root / "bags", write_yaml(root / "mapping.yaml", MAPPING)


@pytest.mark.parametrize(
    ("workers", "executor", "group"),
    [(1, "local", True), (2, "local", False), (2, "local", True), (2, "ray", False)],
    ids=["one-process", "workers-parent-only", "workers-terminal", "ray-parent-only"],
)
def test_ctrl_c_leaves_nothing_and_exits_130(
    tmp_path: Path, long_sources: tuple[Path, Path], workers: int, executor: str, group: bool
) -> None:
    """Ctrl-C while the conversion runs (with --workers: while a worker encodes): exit 130, one line, no
    traceback, no process left behind, nothing under DST or beside it. `group`: the signal reaches the workers
    too, as at a terminal; otherwise only the parent gets it and must stop them itself (a local instance of Ray
    started by the command is shut down with it)."""
    bags, mapping = long_sources
    out = tmp_path / "ds"
    args = ["convert", str(bags), str(out), "--mapping", str(mapping), "--codec", "h264", "--workers", str(workers)]
    args += ["--executor", executor]
    staged = ".ds.partial-{pid}" if workers == 1 else ".ds.workers-{pid}/.worker-*.partial-*"
    code, err = interrupt_when(args, tmp_path, staged + "/videos/*/*/.*.mp4.tmp", group=group)
    assert code == 130, err
    assert err.strip().splitlines()[-1] == f"interrupted: nothing was written to {out}", err
    assert "Traceback" not in err, err
    assert not out.exists()
    assert hidden_leftovers(tmp_path) == []


def test_read_only_destination_is_one_line(tmp_path: Path, sources: tuple[Path, Path]) -> None:
    bags, mapping = sources
    (tmp_path / "src").mkdir()
    with read_only_view(tmp_path / "src", tmp_path / "ro") as ro:
        proc = run_cli("convert", str(bags), str(ro / "ds"), "--mapping", str(mapping), "--codec", "h264")
        assert proc.returncode == 2, proc.stderr
        lines = proc.stderr.strip().splitlines()
        assert lines == [f"error: {ro / 'ds'}: cannot write the output here: Read-only file system"], proc.stderr
        assert snapshot(ro) == {}
