"""`convert SRC_DIR DST --workers N`: the merged dataset equals the one-process conversion of the same bags."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow.parquet as pq
import pytest

from openral_data.convert.own_bags import own_mapping
from openral_data.convert.parallel import convert_parallel, plan_blocks
from openral_data.convert.to_lerobot import convert_bags
from openral_data.errors import UsageError
from openral_data.formats.mcap import finished_bags
from openral_data.record.options import RecordOptions
from openral_data.record.sim import record
from tests.support.cli import run_cli
from tests.support.lerobot import verify_mock_dataset
from tests.support.scenes import mock_scene, write_yaml

LENGTHS = [6, 4, 8, 5, 3]


@pytest.fixture
def bags(project: Path, tmp_path: Path) -> Path:
    """Five mock episodes recorded as five bags (png: lossless, so both conversions see the same pixels)."""
    scene = write_yaml(tmp_path / "s.yaml", mock_scene(success_after=LENGTHS, n_episodes=len(LENGTHS)))
    rec = tmp_path / "rec"
    record(RecordOptions(scene=str(scene), out=rec, formats=("mcap",), image_format="png"))
    return rec / "mcap"


def _frames(root: Path) -> dict[str, list[Any]]:
    return pq.read_table(root / "data").sort_by("index").to_pydict()


def _episodes(root: Path) -> dict[str, list[Any]]:
    return pq.read_table(root / "meta" / "episodes").sort_by("episode_index").to_pydict()


def _decoded(root: Path) -> dict[str, list[np.ndarray]]:
    """Every camera's frames, decoded, in episode order."""
    import av

    out: dict[str, list[np.ndarray]] = {}
    for video in sorted((root / "videos").rglob("*.mp4")):
        camera = video.relative_to(root / "videos").parts[0]
        with av.open(str(video)) as container:
            out.setdefault(camera, []).extend(f.to_ndarray(format="rgb24") for f in container.decode(video=0))
    return out


def _assert_same(seq: Path, par: Path) -> None:
    assert _frames(par) == _frames(seq)
    assert _episodes(par) == _episodes(seq)
    assert json.loads((par / "meta" / "stats.json").read_text()) == json.loads(
        (seq / "meta" / "stats.json").read_text()
    )
    a, b = _decoded(seq), _decoded(par)
    assert a.keys() == b.keys() and a
    for camera in a:
        assert len(b[camera]) == len(a[camera]) == sum(LENGTHS)  # 0 frames lost
        assert all(np.array_equal(x, y) for x, y in zip(a[camera], b[camera], strict=True))


@pytest.mark.slow
def test_workers_equal_one_process(bags: Path, tmp_path: Path) -> None:
    mapping = own_mapping(finished_bags(bags)[0])
    seq = convert_bags(bags, tmp_path / "seq", mapping, codec="h264")
    par = convert_parallel(bags, tmp_path / "par", mapping, 2, codec="h264")
    assert [(e.index, e.length, e.success, e.seed) for e in par.episodes] == [
        (e.index, e.length, e.success, e.seed) for e in seq.episodes
    ]
    assert [e.length for e in par.episodes] == LENGTHS and par.frames == seq.frames == sum(LENGTHS)
    assert par.source_episodes == seq.source_episodes == len(LENGTHS)
    assert par.topics == seq.topics and par.skipped_topics == seq.skipped_topics
    _assert_same(tmp_path / "seq", tmp_path / "par")
    assert verify_mock_dataset(tmp_path / "par", "pyav")["lengths"] == LENGTHS  # lerobot loads it
    assert not [p.name for p in tmp_path.iterdir() if p.name.startswith(".par")]  # no workers' folder left


@pytest.mark.slow
def test_ray_executor_equals_one_process(bags: Path, tmp_path: Path) -> None:
    """A real local Ray instance converts the blocks; the merge equals the one-process conversion."""
    proc = run_cli("convert", str(bags), str(tmp_path / "seq"), "--codec", "h264")
    assert proc.returncode == 0, proc.stderr
    proc = run_cli(
        "convert", str(bags), str(tmp_path / "ray"), "--codec", "h264", "--workers", "2", "--executor", "ray", "--json"
    )
    assert proc.returncode == 0, proc.stderr
    doc = json.loads(proc.stdout)
    assert doc["workers"] == 2 and doc["executor"] == "ray" and doc["frames"] == sum(LENGTHS)
    _assert_same(tmp_path / "seq", tmp_path / "ray")


def test_failed_worker_leaves_nothing(bags: Path, tmp_path: Path) -> None:
    """A bag that breaks one worker: one-line error, exit 2, nothing under DST, no workers' folder left."""
    broken = finished_bags(bags)[-1]
    for mcap in broken.glob("*.mcap"):
        mcap.write_bytes(mcap.read_bytes()[:200])  # truncated
    dst = tmp_path / "out"
    proc = run_cli("convert", str(bags), str(dst), "--codec", "h264", "--workers", "2")
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr.startswith("error: ") and len(proc.stderr.strip().splitlines()) == 1
    assert not dst.exists()
    assert not [p.name for p in tmp_path.iterdir() if ".workers-" in p.name or p.name.startswith(".out")]


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--workers", "0"], "--workers must be >= 1, got 0"),
        (["--workers", "2", "--executor", "dask"], "--executor: 'dask' is not one of local, ray"),
        (["--workers", "2", "--address", "1.2.3.4:6379"], "--address: only with --executor ray"),
    ],
)
def test_bad_flags_are_one_line(tmp_path: Path, args: list[str], message: str) -> None:
    src = tmp_path / "bags"
    src.mkdir()
    proc = run_cli("convert", str(src), str(tmp_path / "out"), *args)
    assert proc.returncode == 2 and proc.stderr.strip() == f"error: {message}", proc.stderr
    assert not (tmp_path / "out").exists()


def test_blocks_are_contiguous_and_in_order() -> None:
    bags = [Path(f"b{k}") for k in range(5)]
    assert plan_blocks(bags, 2) == [bags[:3], bags[3:]]
    assert plan_blocks(bags, 9) == [[b] for b in bags]
    with pytest.raises(UsageError):
        plan_blocks(bags, 0)
