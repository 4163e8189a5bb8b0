"""`doctor` on damaged copies of a fresh recording: every corruption class is an error finding with its code and
exit status 1 — never a traceback — with and without `--repair`, and `--repair` refuses to rewrite a dataset
it cannot read (leaving its files byte-identical). `--deep` catches swapped video content no other check sees."""

from __future__ import annotations

import json
import shutil
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from openral_data.doctor import check, repair
from openral_data.doctor.command import run_doctor
from openral_data.formats.lerobot_v3 import digests, layout
from openral_data.formats.lerobot_v3.clip import episode_clip
from openral_data.formats.lerobot_v3.video import concat_mp4
from tests.support.cli import run_cli
from tests.support.recorded import record_mock_cli

# episodes 0 and 9 have the same length; their frames differ by 9 levels of green (the mock's G = episode)
LENGTHS = [4, 5, 5, 5, 5, 5, 5, 5, 5, 4]
FPS = 20
FRONT = "videos/observation.images.front/chunk-000/file-000.mp4"
FRONT_KEY = "observation.images.front"
DATA = "data/chunk-000/file-000.parquet"
EPISODES = "meta/episodes/chunk-000/file-000.parquet"


@pytest.fixture(scope="module")
def fresh(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return record_mock_cli(tmp_path_factory.mktemp("corruption"), LENGTHS, fps=FPS)


def _info(root: Path, **changes: object) -> None:
    info = json.loads((root / layout.INFO_PATH).read_text())
    info.update(changes)
    (root / layout.INFO_PATH).write_text(json.dumps(info, indent=4))


def _set(table: pa.Table, name: str, values: pa.Array) -> pa.Table:
    return table.set_column(table.schema.get_field_index(name), name, values)


# -- the issue's classes ------------------------------------------------------------------------------------------
def data_truncated(root: Path) -> None:
    raw = (root / DATA).read_bytes()
    (root / DATA).write_bytes(raw[: len(raw) // 2])


def data_empty(root: Path) -> None:
    (root / DATA).write_bytes(b"")


def data_garbage(root: Path) -> None:
    (root / DATA).write_bytes(bytes(range(256)) * 40)


def frame_index_bit_flip(root: Path) -> None:
    t = pq.read_table(root / DATA)
    fi = t["frame_index"].to_numpy().copy()
    fi[2] ^= 1 << 40
    pq.write_table(_set(t, "frame_index", pa.array(fi)), root / DATA)


def state_value_flipped(root: Path) -> None:
    """One float of observation.state changed: the file is valid parquet and every structural check passes."""
    t = pq.read_table(root / DATA)
    col = t["observation.state"].combine_chunks()
    flat = col.flatten().to_numpy().copy()
    flat[7] += 0.5
    pq.write_table(
        _set(t, "observation.state", pa.FixedSizeListArray.from_arrays(flat, col.type.list_size)), root / DATA
    )


def _swap_front_content(root: Path, a: int, b: int) -> None:
    """Exchange the frames of two equal-length episodes inside the front camera's mp4 (packets only)."""
    rows = pq.read_table(root / EPISODES).to_pylist()
    clips = []
    for r in rows:
        lo, hi = r[f"videos/{FRONT_KEY}/from_timestamp"], r[f"videos/{FRONT_KEY}/to_timestamp"]
        clip = episode_clip(root / FRONT, lo, hi, FPS)
        assert clip.data is not None and clip.frames == r["length"]
        path = root / f"clip-{r['episode_index']}.mp4"
        path.write_bytes(clip.data)
        clips.append((path, int(r["length"])))
    clips[a], clips[b] = clips[b], clips[a]
    concat_mp4(clips, root / "swapped.mp4", FPS)
    (root / "swapped.mp4").replace(root / FRONT)
    for path, _ in clips:
        path.unlink()


def swapped_video_content(root: Path) -> None:
    _swap_front_content(root, 0, 9)


def duplicated_task_strings(root: Path) -> None:
    t = pq.read_table(root / layout.TASKS_PATH)
    dup = pa.table({"task_index": [0, 1], "task": t["task"].to_pylist() * 2}, schema=t.schema)
    pq.write_table(dup, root / layout.TASKS_PATH)
    _info(root, total_tasks=2)


def nonstandard_path_template(root: Path) -> None:
    _info(root, data_path="data/chunk-{chunk_index:03d}/../file-{file_index:03d}.parquet")


def dropped_row_length_lowered(root: Path) -> None:
    """Episode 0's last frame row removed and everything numeric made to agree: length, index, ranges, totals,
    to_timestamp. Only its video still holds the dropped frame."""
    t = pq.read_table(root / DATA)
    keep = np.ones(t.num_rows, dtype=bool)
    keep[LENGTHS[0] - 1] = False
    t = t.filter(pa.array(keep))
    pq.write_table(_set(t, "index", pa.array(np.arange(t.num_rows, dtype=np.int64))), root / DATA)
    ep = pq.read_table(root / EPISODES)
    rows = ep.to_pylist()
    rows[0]["length"] -= 1
    start = 0
    for r in rows:
        r["dataset_from_index"], r["dataset_to_index"] = start, start + r["length"]
        start += r["length"]
    for key in ("observation.images.front", "observation.images.wrist"):
        rows[0][f"videos/{key}/to_timestamp"] = rows[0]["length"] / FPS
    pq.write_table(pa.Table.from_pylist(rows, schema=ep.schema), root / EPISODES)
    _info(root, total_frames=start)


# -- more damage doctor used to crash on ----------------------------------------------------------------------
def data_page_byte_flip(root: Path) -> None:
    """A flipped byte inside a data page (the frame_index column chunk): the page checksum no longer matches."""
    meta = pq.ParquetFile(root / DATA).metadata
    names = [meta.schema.column(i).name for i in range(meta.num_columns)]
    chunk = meta.row_group(0).column(names.index("frame_index"))
    raw = bytearray((root / DATA).read_bytes())
    raw[chunk.data_page_offset + chunk.total_compressed_size - 2] ^= 0x10
    (root / DATA).write_bytes(bytes(raw))


def episodes_garbage(root: Path) -> None:
    (root / EPISODES).write_bytes(b"PAR1" + b"\x00" * 64 + b"PAR1")


def tasks_garbage(root: Path) -> None:
    (root / layout.TASKS_PATH).write_bytes(b"not a parquet file")


def video_garbage(root: Path) -> None:
    (root / FRONT).write_bytes(b"\x00\x00\x00\x18ftypmp42" + b"\xff" * 500)


def info_features_list(root: Path) -> None:
    _info(root, features=["observation.state", "action"])


def info_fps_zero(root: Path) -> None:
    _info(root, fps=0)


def info_totals_strings(root: Path) -> None:
    _info(root, total_frames="48", total_episodes="ten")


# (corruption, finding code, needs --deep, repair must refuse to rewrite anything)
CLASSES: list[tuple[Callable[[Path], None], str, bool, bool]] = [
    (data_truncated, "data.unreadable", False, True),
    (data_empty, "data.unreadable", False, True),
    (data_garbage, "data.unreadable", False, True),
    (frame_index_bit_flip, "data.frame_index", False, True),
    (state_value_flipped, "file.digest", False, False),
    (swapped_video_content, "video.content", True, False),
    (duplicated_task_strings, "tasks.duplicate", False, False),
    (nonstandard_path_template, "file.digest", False, False),
    (dropped_row_length_lowered, "video.ranges", False, False),
    (data_page_byte_flip, "data.unreadable", False, True),
    (episodes_garbage, "episodes.unreadable", False, True),
    (tasks_garbage, "tasks.unreadable", False, True),
    (video_garbage, "video.unreadable", False, True),
    (info_features_list, "info.features", False, True),
    (info_fps_zero, "info.fps", False, True),
    (info_totals_strings, "info.types", False, True),
]
ISSUE_CLASSES = 9  # the first nine rows: the issue's list (its "11" counts truncated/empty/garbage as one each)


def _files(root: Path) -> dict[str, bytes]:
    return {str(p.relative_to(root)): p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()}


def test_fresh_recording_is_healthy_deep_too(fresh: Path) -> None:
    assert check(fresh, deep=True) == []
    stored = digests.read(fresh)
    assert stored is not None and {layout.INFO_PATH, DATA, EPISODES, layout.TASKS_PATH, FRONT} <= set(stored)
    assert pq.ParquetFile(fresh / DATA).metadata is not None


def test_every_class_is_counted() -> None:
    assert len({c[0].__name__ for c in CLASSES}) == len(CLASSES) >= 16
    assert len(CLASSES[:ISSUE_CLASSES]) == 9


@pytest.mark.parametrize(("corrupt", "code", "deep", "refuse"), CLASSES, ids=[c[0].__name__ for c in CLASSES])
def test_detected_never_raises(
    fresh: Path, tmp_path: Path, corrupt: Callable[[Path], None], code: str, deep: bool, refuse: bool
) -> None:
    root = shutil.copytree(fresh, tmp_path / "ds")
    corrupt(root)
    found = check(root, deep=deep)
    assert code in {f.code for f in found}, [f.line() for f in found]
    assert next(f for f in found if f.code == code).severity == "error"
    text, status = run_doctor(root, False, deep)
    assert status == 1, text
    before = _files(root)
    text, status = run_doctor(root, True, deep)
    assert status == 1, text
    if refuse:
        assert "refused  nothing rewritten" in text, text
        after = {k: v for k, v in _files(root).items() if not k.startswith(".openral/")}
        assert after == {k: v for k, v in before.items() if not k.startswith(".openral/")}


def test_a_flipped_value_is_found_only_by_its_digest(fresh: Path, tmp_path: Path) -> None:
    root = shutil.copytree(fresh, tmp_path / "ds")
    state_value_flipped(root)
    found = check(root)
    assert [(f.code, f.where) for f in found] == [("file.digest", DATA)], [f.line() for f in found]
    (root / digests.DIGESTS_PATH).unlink()  # a dataset another tool wrote: nothing to compare, no finding
    assert check(root) == []


def test_repair_takes_over_the_digests_of_files_it_rewrites(fresh: Path, tmp_path: Path) -> None:
    root = shutil.copytree(fresh, tmp_path / "ds")
    ep = pq.read_table(root / EPISODES)
    pq.write_table(ep.take(pa.array(range(ep.num_rows - 1, -1, -1))), root / EPISODES)
    assert {"episodes.order", "file.digest"} <= {f.code for f in check(root)}
    result = repair(root)
    assert result.remaining == [] and result.refused == [], [f.line() for f in result.remaining]


def test_swapped_ranges_plain_and_deep(fresh: Path, tmp_path: Path) -> None:
    """Swapped from/to timestamps of two equal-length episodes: out of order for plain doctor, the wrong
    frames for --deep. Swapped frames under the right timestamps: only --deep sees them (without digests)."""
    root = shutil.copytree(fresh, tmp_path / "ranges")
    (root / digests.DIGESTS_PATH).unlink()
    ep = pq.read_table(root / EPISODES)
    rows = ep.to_pylist()
    for c in ("from_timestamp", "to_timestamp"):
        col = f"videos/{FRONT_KEY}/{c}"
        rows[0][col], rows[9][col] = rows[9][col], rows[0][col]
    pq.write_table(pa.Table.from_pylist(rows, schema=ep.schema), root / EPISODES)
    assert "video.ranges" in {f.code for f in check(root)}
    assert "video.content" in {f.code for f in check(root, deep=True)}

    root = shutil.copytree(fresh, tmp_path / "content")
    (root / digests.DIGESTS_PATH).unlink()
    swapped_video_content(root)
    assert check(root) == []
    deep = check(root, deep=True)
    assert [(f.code, f.where) for f in deep] == [("video.content", FRONT)], [f.line() for f in deep]
    assert "episode(s) [0, 9]" in deep[0].message


def test_cli_deep_and_no_traceback(fresh: Path, tmp_path: Path) -> None:
    root = shutil.copytree(fresh, tmp_path / "ds")
    ok = run_cli("doctor", str(root), "--deep")
    assert ok.returncode == 0 and ok.stdout.strip().endswith(": healthy"), ok.stdout + ok.stderr
    data_garbage(root)
    for args in ((), ("--repair",)):
        done = run_cli("doctor", str(root), *args)
        assert done.returncode == 1 and done.stderr == "", done.stderr
        assert f"error   {DATA}: unreadable parquet" in done.stdout, done.stdout
