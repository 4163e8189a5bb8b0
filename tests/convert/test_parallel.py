"""`convert SRC_DIR DST --workers N`: the merged dataset equals the one-process conversion of the same bags."""

from __future__ import annotations

import itertools
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
from openral_data.schemas.mapping import load_mapping
from tests.support import layout_bags as lb
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


SPLIT_MAPPING = {
    "fps": 10,
    "task": "pick",
    "state": {
        "parts": [
            {"topic": "/arm/joint_states", "field": "position", "joints": ["j1", "j2", "j3"]},
            {"topic": "/gripper/joint_states", "field": "position"},
        ]
    },
    "action": {"parts": [{"topic": "/arm/cmd", "field": "data"}, {"topic": "/gripper/cmd", "field": "data"}]},
}


def _layout_bags(root: Path, broken: bool) -> Path:
    """Three camera-less rosbag2 bags; with `broken`, the last one's /gripper/cmd widens after 0.5 s, which only
    its conversion finds (the up-front checks read each topic's first message)."""
    root.mkdir()
    for name in ("a", "b", "c"):
        width = (lambda k: 1 if k < 5 else 2) if broken and name == "c" else (lambda k: 1)
        lb.write_ros2(root / name, lb.split(gripper_cmd_width=width))
    return root


def test_failed_worker_leaves_nothing(tmp_path: Path) -> None:
    """A bag that breaks one worker mid-conversion: one-line error, exit 2, nothing under DST, no workers' folder."""
    src = _layout_bags(tmp_path / "bags", broken=True)
    mapping = write_yaml(tmp_path / "m.yaml", SPLIT_MAPPING)
    dst = tmp_path / "out"
    proc = run_cli("convert", str(src), str(dst), "--mapping", str(mapping), "--workers", "2")
    assert proc.returncode == 2, proc.stderr
    line = proc.stderr.strip()
    assert len(line.splitlines()) == 1 and line.startswith(f"error: {src / 'c'}"), line
    assert line.endswith("mapping: action.parts[1] (/gripper/cmd.data): vector length changed from 1 to 2"), line
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bags", "m.yaml"]


def test_camera_less_bags_in_parallel(tmp_path: Path) -> None:
    """Bags without cameras merge too (no camera statistics to sum); the frames equal one process's."""
    src = _layout_bags(tmp_path / "bags", broken=False)
    mapping = load_mapping(write_yaml(tmp_path / "m.yaml", SPLIT_MAPPING))
    seq = convert_bags(src, tmp_path / "seq", mapping)
    par = convert_parallel(src, tmp_path / "par", mapping, 2)
    assert par.frames == seq.frames > 0 and len(par.episodes) == len(seq.episodes) == 3
    assert _frames(tmp_path / "par") == _frames(tmp_path / "seq")
    assert _episodes(tmp_path / "par") == _episodes(tmp_path / "seq")


def test_progress_counts_as_one_process_and_advances_within_blocks(tmp_path: Path) -> None:
    """The callback sees the mapped messages read, summed over the workers as they report them: increasing values
    from 0 to the total one process counts, with steps inside the blocks (not just one per finished block)."""
    src = _layout_bags(tmp_path / "bags", broken=False)
    mapping = load_mapping(write_yaml(tmp_path / "m.yaml", SPLIT_MAPPING))
    seq: list[tuple[int, int]] = []
    convert_bags(src, tmp_path / "seq", mapping, progress=lambda d, t: seq.append((d, t)))
    par: list[tuple[int, int]] = []
    convert_parallel(src, tmp_path / "par", mapping, 2, progress=lambda d, t: par.append((d, t)))
    total = seq[-1][1]
    assert seq[-1] == (total, total) and total > 64 * 3  # several reports per bag
    assert {t for _, t in par} == {total}
    done = [d for d, _ in par]
    assert done[0] == 0 and done[-1] == total
    assert all(a < b for a, b in itertools.pairwise(done)), done
    assert len(done) > 2 + 1, done  # more than the start and one step per block (2 blocks)


@pytest.mark.parametrize("workers", [2, 3])
def test_task_text_carries_across_blocks(tmp_path: Path, workers: int) -> None:
    """One process carries a bag's last task message into the next bag; each block starts with that carry too."""
    src = tmp_path / "bags"
    src.mkdir()
    # every bag has the topic (mapped topics must exist), but b and c only late: their first frames take the
    # previous bag's last task
    tasks = {"a": [(0, "pick red")], "b": [(900, "pick blue")], "c": [(500, "place")]}  # ms into each bag
    for name, messages in tasks.items():
        task = [lb.Sample("/task", lb.BASE + ms * lb.MS, {"data": text}) for ms, text in messages]
        lb.write_ros2(src / name, lb.split() + task)
    mapping = load_mapping(write_yaml(tmp_path / "m.yaml", {**SPLIT_MAPPING, "task": None, "task_topic": "/task"}))
    seq = convert_bags(src, tmp_path / "seq", mapping)
    par = convert_parallel(src, tmp_path / "par", mapping, workers)
    assert seq.unfillable_frames == par.unfillable_frames and par.frames == seq.frames
    # b's first frames took a's task; c's took b's only from the carried message's time on (the bags share a
    # clock base, so b's message at 0.9 s is later than c's first frames, which are unfillable until c's own)
    assert [e.length for e in seq.episodes] == [10, 10, 5] and seq.unfillable_frames == 5
    assert _frames(tmp_path / "par") == _frames(tmp_path / "seq")
    read = pq.read_table(tmp_path / "par" / "meta" / "tasks.parquet").to_pydict()
    assert sorted(str(v) for col in read.values() for v in col if isinstance(v, str)) == [
        "pick blue",
        "pick red",
        "place",
    ]


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
