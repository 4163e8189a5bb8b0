"""A killed `episodes merge` leaves nothing under its --out (no dataset lerobot could load) and only its hidden
staging folder; the next merge into the same parent is not refused, removes it and leaves no hidden leftovers.
A killed `episodes delete --in-place` leaves the input byte-identical."""

from __future__ import annotations

from pathlib import Path

import pytest

from openral_data.record.options import RecordOptions
from openral_data.record.sim import record
from tests.support.cli import run_cli
from tests.support.interrupt import hidden_leftovers, kill_when_staged, snapshot
from tests.support.scenes import mock_scene, write_yaml
from tests.support.seeded import verify_seeded_dataset
from tests.support.timing import TIMED

pytestmark = [TIMED, pytest.mark.slow]
N = 8


def _sources(project: Path, tmp_path: Path, names: str) -> list[Path]:
    scene = write_yaml(
        project / "scenes/sim/mock_kill.yaml",
        mock_scene(scene_id="mock_kill", success_after=[6, 9, 4], n_episodes=N, seeded=True),
    )
    sources = [tmp_path / name for name in names]
    for k, src in enumerate(sources):
        record(RecordOptions(scene=str(scene), out=src, codec="h264", seed=k * N, n_episodes=N))
    return sources


def test_killed_merge_leaves_no_dataset_and_rerun_succeeds(project: Path, tmp_path: Path) -> None:
    sources = _sources(project, tmp_path, "ab")
    parent = tmp_path / "merged"
    parent.mkdir()
    out = parent / "ab"
    args = ["episodes", "merge", *map(str, sources), "--out", str(out)]
    killed = kill_when_staged(args, out, "data/*/*.parquet")  # at least one episode committed
    assert not out.exists()
    assert hidden_leftovers(parent) == [f".ab.partial-{killed.pid}", f".ab.partial-{killed.pid}.owner"]
    proc = run_cli(*args)
    assert proc.returncode == 0, proc.stderr
    verify_seeded_dataset(out)
    assert hidden_leftovers(parent) == []


def test_killed_delete_in_place_leaves_the_input_whole(project: Path, tmp_path: Path) -> None:
    (dataset,) = _sources(project, tmp_path, "a")
    before = snapshot(dataset)
    args = ["episodes", "delete", str(dataset), "--episodes", "0", "--in-place"]
    kill_when_staged(args, dataset, "data/*/*.parquet", nested=True)
    after = snapshot(dataset)
    assert after.pop(".openral/lock", None) is not None  # the killed writer's lock file (stale: the lock died)
    assert after == before
    verify_seeded_dataset(dataset)
    proc = run_cli(*args)
    assert proc.returncode == 0, proc.stderr
    assert len(verify_seeded_dataset(dataset)["lengths"]) == N - 1
    assert hidden_leftovers(tmp_path) == []
