"""A killed `episodes merge` leaves nothing under its --out (no dataset lerobot could load) and only its hidden
staging folder; the next merge into the same parent is not refused, removes it and leaves no hidden leftovers."""

from __future__ import annotations

from pathlib import Path

import pytest

from openral_data.record.options import RecordOptions
from openral_data.record.sim import record
from tests.support.cli import run_cli
from tests.support.interrupt import hidden_leftovers, kill_when_staged
from tests.support.scenes import mock_scene, write_yaml
from tests.support.seeded import verify_seeded_dataset
from tests.support.timing import TIMED

pytestmark = [TIMED, pytest.mark.slow]
N = 8


def test_killed_merge_leaves_no_dataset_and_rerun_succeeds(project: Path, tmp_path: Path) -> None:
    scene = write_yaml(
        project / "scenes/sim/mock_kill.yaml",
        mock_scene(scene_id="mock_kill", success_after=[6, 9, 4], n_episodes=N, seeded=True),
    )
    sources = [tmp_path / "a", tmp_path / "b"]
    for k, src in enumerate(sources):
        record(RecordOptions(scene=str(scene), out=src, codec="h264", seed=k * N, n_episodes=N))
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
