"""`doctor`: each deliberately corrupted copy of a real recording is detected with the right finding, and the
repairable ones come back healthy and frame-exact in lerobot 0.6.1's own loader."""

from __future__ import annotations

import json
import shutil
from collections.abc import Callable
from pathlib import Path

import av
import numpy as np
import pyarrow as pa
import pyarrow.compute as pc
import pyarrow.parquet as pq
import pytest

from openral_data.doctor import check, repair
from openral_data.errors import DatasetBusy
from openral_data.formats import atomic
from openral_data.formats.lerobot_v3 import digests, layout
from openral_data.formats.lerobot_v3.lock import DatasetLock
from tests.support.cli import run_cli
from tests.support.lerobot import verify_mock_dataset
from tests.support.lerobot_written import write_lerobot_dataset
from tests.support.recorded import record_mock_cli

LENGTHS = [5, 7, 4]
FRONT = "videos/observation.images.front/chunk-000/file-000.mp4"
DATA = "data/chunk-000/file-000.parquet"
EPISODES = "meta/episodes/chunk-000/file-000.parquet"


@pytest.fixture(scope="module")
def healthy(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return record_mock_cli(tmp_path_factory.mktemp("doctor"), LENGTHS)


def _table(root: Path, rel: str) -> pa.Table:
    return pq.read_table(root / rel)


def _write(root: Path, rel: str, table: pa.Table) -> None:
    pq.write_table(table, root / rel)


def _info(root: Path, **changes: object) -> None:
    info = json.loads((root / layout.INFO_PATH).read_text())
    info.update(changes)
    (root / layout.INFO_PATH).write_text(json.dumps(info, indent=4))


def _total(root: Path, key: str) -> int:
    return int(json.loads((root / layout.INFO_PATH).read_text())[key])


def tasks_without_pandas_index(root: Path) -> None:
    t = _table(root, layout.TASKS_PATH)
    _write(root, layout.TASKS_PATH, t.replace_schema_metadata(None))


def tasks_out_of_order(root: Path) -> None:
    t = _table(root, layout.TASKS_PATH)
    extra = pa.table({"task_index": [1], "task": ["an unused second task"]}, schema=t.schema)
    _write(root, layout.TASKS_PATH, pa.concat_tables([extra, t]))
    _info(root, total_tasks=2)


def _reverse(root: Path, rel: str) -> None:
    t = _table(root, rel)
    _write(root, rel, t.take(pa.array(range(t.num_rows - 1, -1, -1))))


def episodes_reversed(root: Path) -> None:
    _reverse(root, EPISODES)


def index_offset(root: Path) -> None:
    t = _table(root, DATA)
    i = t.schema.get_field_index("index")
    _write(root, DATA, t.set_column(i, "index", pc.add(t["index"], 1000)))


def rows_reversed(root: Path) -> None:
    _reverse(root, DATA)


def timestamp_plus_1ms(root: Path) -> None:
    t = _table(root, DATA)
    i = t.schema.get_field_index("timestamp")
    _write(root, DATA, t.set_column(i, "timestamp", pc.add(t["timestamp"], pa.scalar(1e-3, pa.float32()))))


def extra_column(root: Path) -> None:
    t = _table(root, DATA)
    _write(root, DATA, t.append_column("junk", pa.array(np.zeros(t.num_rows))))


def missing_column(root: Path) -> None:
    t = _table(root, DATA)
    _write(root, DATA, t.drop_columns(["action"]))


def total_frames_too_small(root: Path) -> None:
    _info(root, total_frames=_total(root, "total_frames") - 1)


def total_episodes_too_big(root: Path) -> None:
    _info(root, total_episodes=_total(root, "total_episodes") + 1)


def killed_between_renames(root: Path) -> None:
    """A writer killed after the data parquet of a 4th episode landed, before its metadata did."""
    t = _table(root, DATA)
    last = t.filter(pc.equal(t["episode_index"], 2))
    n = t.num_rows
    ep = last.schema.get_field_index("episode_index")
    ix = last.schema.get_field_index("index")
    extra = last.set_column(ep, "episode_index", pa.array([3] * last.num_rows, pa.int64()))
    extra = extra.set_column(ix, "index", pa.array(range(n, n + last.num_rows), pa.int64()))
    _write(root, DATA, pa.concat_tables([t, extra]))


def from_timestamp_plus_10ms(root: Path) -> None:
    t = _table(root, EPISODES)
    col = "videos/observation.images.front/from_timestamp"
    values = t[col].to_pylist()
    values[1] += 0.01
    _write(root, EPISODES, t.set_column(t.schema.get_field_index(col), col, pa.array(values, pa.float64())))


def interrupted_commit(root: Path) -> None:
    batch = atomic.Batch(journal=root / layout.JOURNAL_PATH)
    batch.write_with(root / layout.INFO_PATH, atomic.bytes_writer((root / layout.INFO_PATH).read_bytes()))
    batch.write_journal()  # killed before the renames


def staged_leftover(root: Path) -> None:
    (root / "videos/observation.images.front/chunk-000/.file-001.mp4.tmp").write_bytes(b"half an episode")


def orphan_video(root: Path) -> None:
    shutil.copy(root / FRONT, root / "videos/observation.images.front/chunk-000/file-007.mp4")


def video_one_frame_short(root: Path) -> None:
    path = root / FRONT
    tmp = path.with_name("short.mp4")
    with av.open(str(path)) as src, av.open(str(tmp), "w", format="mp4") as dst:
        stream_in = src.streams.video[0]
        stream_out = dst.add_stream_from_template(stream_in)
        packets = [p for p in src.demux(stream_in) if p.dts is not None]
        last = max(p.pts for p in packets if p.pts is not None)
        for p in packets:
            if p.pts != last:
                p.stream = stream_out
                dst.mux(p)
    tmp.replace(path)


def video_missing(root: Path) -> None:
    (root / FRONT).unlink()


def version_2(root: Path) -> None:
    _info(root, codebase_version="v2.1")


# (corruption, finding code, repairable)
CASES: list[tuple[Callable[[Path], None], str, bool]] = [
    (tasks_without_pandas_index, "tasks.pandas_index", True),
    (tasks_out_of_order, "tasks.order", True),
    (episodes_reversed, "episodes.order", True),
    (index_offset, "data.index", True),
    (rows_reversed, "data.order", True),
    (timestamp_plus_1ms, "data.timestamp", True),
    (extra_column, "data.extra_column", True),
    (total_frames_too_small, "info.totals", True),
    (total_episodes_too_big, "info.totals", True),
    (killed_between_renames, "info.totals", True),
    (from_timestamp_plus_10ms, "video.timestamps", True),
    (interrupted_commit, "writer.journal", True),
    (staged_leftover, "writer.staged", True),
    (orphan_video, "video.orphan", True),
    (missing_column, "data.missing_column", False),
    (video_one_frame_short, "video.frames", False),
    (video_missing, "video.missing", False),
    (version_2, "info.version", False),
]


def test_recording_is_healthy(healthy: Path) -> None:
    assert check(healthy) == []


@pytest.mark.parametrize(("corrupt", "code", "repairable"), CASES, ids=[c[0].__name__ for c in CASES])
def test_detects_and_repairs(
    healthy: Path, tmp_path: Path, corrupt: Callable[[Path], None], code: str, repairable: bool
) -> None:
    root = shutil.copytree(healthy, tmp_path / "ds")
    # as a dataset another tool wrote: the content digests would flag every one of these edits as file.digest
    # (tests/doctor/test_corruption.py); here the structural check and its repair are under test
    (root / digests.DIGESTS_PATH).unlink()
    corrupt(root)
    found = check(root)
    assert code in {f.code for f in found}, [f.line() for f in found]
    mine = next(f for f in found if f.code == code)
    assert mine.repairable is repairable, mine.line()
    before = sorted(p.relative_to(root) for p in root.rglob("*") if p.is_file() and ".openral" not in p.parts)
    result = repair(root)
    remaining = {f.code for f in result.remaining}
    if not repairable:
        assert code in remaining, result
        return
    assert result.remaining == [], [f.line() for f in result.remaining]
    assert result.actions, result
    # nothing was lost: every file replaced or taken out has its original under the quarantine
    assert result.quarantine is not None or code == "writer.journal"
    seen = verify_mock_dataset(root, "pyav")
    assert seen["lengths"] == LENGTHS
    if result.quarantine is not None:
        kept = {p.relative_to(result.quarantine) for p in result.quarantine.rglob("*") if p.is_file()}
        gone = [p for p in before if not (root / p).exists()]
        assert all(p in kept for p in gone), (gone, kept)


def test_repair_refuses_while_a_writer_holds_the_lock(healthy: Path, tmp_path: Path) -> None:
    root = shutil.copytree(healthy, tmp_path / "ds")
    with DatasetLock(root, "a test writer"):
        assert "writer.active" in {f.code for f in check(root)}
        with pytest.raises(DatasetBusy) as excinfo:
            repair(root)
        assert excinfo.value.code == "dataset.busy" and "a test writer" in excinfo.value.holder
    assert check(root) == []


def test_cli_exit_codes_and_lines(healthy: Path, tmp_path: Path) -> None:
    root = shutil.copytree(healthy, tmp_path / "ds")
    episodes_reversed(root)
    found = run_cli("doctor", str(root))
    assert found.returncode == 1, found.stderr
    assert "error   meta/episodes: rows are not episode 0, 1, 2" in found.stdout and "[repairable]" in found.stdout
    fixed = run_cli("doctor", str(root), "--repair")
    assert fixed.returncode == 0, fixed.stdout + fixed.stderr
    assert "repaired meta/episodes: rows put back in episode order" in fixed.stdout
    assert fixed.stdout.strip().endswith(": healthy")
    missing = run_cli("doctor", str(tmp_path / "nope"))  # a path that names nothing is bad input, before any check
    assert missing.returncode == 2 and missing.stderr.strip().endswith("nope: no such file or directory")


@pytest.mark.slow
def test_lerobot_written_dataset_is_healthy_and_repairs(tmp_path: Path) -> None:
    root = tmp_path / "lerobot"
    write_lerobot_dataset(root, with_success=True)
    assert check(root) == []
    tasks_without_pandas_index(root)
    episodes_reversed(root)
    assert {"tasks.pandas_index", "episodes.order"} <= {f.code for f in check(root)}
    assert repair(root).remaining == []
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    ds = LeRobotDataset("local/repaired", root=root, video_backend="pyav")
    for i in range(len(ds)):
        item = ds[i]
        e, t = int(item["episode_index"]), int(item["frame_index"])
        assert item["task"] == "push the block" and item["observation.state"].tolist()[:2] == [t, e]
        assert abs(float(item["observation.images.cam"].mean()) * 255 - 10 * t) < 4
