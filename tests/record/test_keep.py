"""`record --keep success`: an episode that does not succeed is discarded, takes no episode number, and is counted."""

from __future__ import annotations

import json
from pathlib import Path

import pyarrow.parquet as pq
import pytest

from tests.support.inproc import run_inproc
from tests.support.scenes import mock_scene, write_yaml


@pytest.mark.parametrize("workers", ["1", "2"])
def test_keep_success_discards_failures(tmp_path: Path, workers: str) -> None:
    scene = write_yaml(tmp_path / "s.yaml", mock_scene(success_after=[2, 99, 3, 99], max_steps=6, n_episodes=4))
    out = tmp_path / "ds"
    r = run_inproc(
        "record", "--scene", str(scene), "--out", str(out), "--keep", "success", "--workers", workers, "--json"
    )
    assert r.returncode == 0, r.stderr
    doc = json.loads(r.stdout)
    assert doc["episodes"] == 2 and doc["discarded"] == 2 and doc["successes"] == 2, doc
    rows = [row for f in sorted((out / "meta" / "episodes").rglob("*.parquet")) for row in pq.read_table(f).to_pylist()]
    assert [row["episode_index"] for row in rows] == [0, 1]
    assert [row["openral.seed"] for row in rows] == [0, 2]  # the attempts' own seeds
    assert all(row["openral.success"] for row in rows)


def test_keep_refusals(tmp_path: Path) -> None:
    r = run_inproc("record", "--out", str(tmp_path / "a"), "--keep", "maybe")
    assert r.returncode == 2 and "--keep" in r.stderr
    r = run_inproc("record", "--out", str(tmp_path / "b"), "--keep", "success", "--resume")
    assert r.returncode == 2 and "--keep success" in r.stderr
