"""Health checks on deliberately broken copies of a real recording."""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path

import av
import numpy as np
import pyarrow as pa
import pyarrow.compute as pc
import pyarrow.parquet as pq
import pytest

from openral_data.formats.lerobot_v3.video import count_packets
from openral_data.metrics.command import StatsOptions, run_stats
from tests.support.cli import run_cli
from tests.support.metrics import copy_dataset, data_file, record_datasets, rewrite_parquet


@pytest.fixture(scope="module")
def healthy(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Path]:
    a, _ = record_datasets(tmp_path_factory.mktemp("health"))
    yield a


def _issues(root: Path) -> list[tuple[int | None, str, str]]:
    report = json.loads(run_stats(StatsOptions([str(root)], fmt="json")))
    return [(h["episode"], h["check"], h["detail"]) for h in report["health"]]


def _checks(root: Path) -> set[tuple[int | None, str]]:
    return {(e, c) for e, c, _ in _issues(root)}


def _set_column(root: Path, name: str, fn: object) -> None:
    path = data_file(root)
    table = pq.read_table(path)
    col = table.column(name).combine_chunks()
    new = fn(table, col)  # type: ignore[operator]
    rewrite_parquet(path, table.set_column(table.schema.get_field_index(name), name, new))


def _episode_rows(table: pa.Table, episode: int) -> np.ndarray:
    return np.flatnonzero(np.asarray(table.column("episode_index").to_numpy()) == episode)


def test_recorded_dataset_is_healthy(healthy: Path) -> None:
    assert _issues(healthy) == []


def test_missing_video_and_data_files(healthy: Path, tmp_path: Path) -> None:
    """Absent files (a partial download) are one `missing_file` row per kind, not one per episode, and the
    episodes whose data is absent are not counted as zero-frame episodes (#30)."""
    ds = copy_dataset(healthy, tmp_path / "missing")
    (ds / "videos/observation.images.wrist/chunk-000/file-000.mp4").unlink()
    found = _issues(ds)
    assert [(e, c) for e, c, _ in found] == [(None, "missing_file")]
    assert found[0][2].startswith("videos/observation.images.wrist: 1 of 1 files (file-000.mp4) not downloaded")
    assert "--include 'videos/observation.images.wrist/*'" in found[0][2]

    data_file(ds).unlink()
    found = _issues(ds)
    assert [(e, c) for e, c, _ in found] == [(None, "missing_file")] * 2
    assert found[0][2].startswith("data: 1 of 1 files (file-000.parquet) not downloaded, episode(s) [0, 1, 2, 3, 4] …")


def test_timestamp_gap_and_non_monotonic(healthy: Path, tmp_path: Path) -> None:
    ds = copy_dataset(healthy, tmp_path / "timestamps")

    def broken(table: pa.Table, col: pa.Array) -> pa.Array:
        ts = np.asarray(col.to_numpy(), dtype=np.float32).copy()
        gap = _episode_rows(table, 1)
        ts[gap[3:]] += 0.5  # a 0.55 s step at 20 fps
        back = _episode_rows(table, 4)
        ts[back[2]], ts[back[3]] = ts[back[3]], ts[back[2]]  # one step backwards
        return pa.array(ts)

    _set_column(ds, "timestamp", broken)
    found = _issues(ds)
    assert {(e, c) for e, c, _ in found} == {(1, "timestamp_gap"), (4, "timestamp_non_monotonic"), (4, "timestamp_gap")}
    assert any("longest 0.55 s" in d for e, c, d in found if (e, c) == (1, "timestamp_gap"))


def test_nan_and_inf(healthy: Path, tmp_path: Path) -> None:
    ds = copy_dataset(healthy, tmp_path / "nonfinite")

    def poison(episode: int, row: int, value: float, dim: int):  # type: ignore[no-untyped-def]
        def fn(table: pa.Table, col: pa.Array) -> pa.Array:
            values = np.asarray(col.flatten().to_numpy(), dtype=np.float32).reshape(len(col), -1).copy()
            values[_episode_rows(table, episode)[row], dim] = value
            return pa.FixedSizeListArray.from_arrays(pa.array(values.ravel()), values.shape[1])

        return fn

    _set_column(ds, "action", poison(0, 2, float("nan"), 3))
    _set_column(ds, "observation.state", poison(6, 1, float("inf"), 0))
    found = [(e, c, d) for e, c, d in _issues(ds)]
    assert [(e, c) for e, c, _ in found] == [(0, "non_finite"), (6, "non_finite")]
    assert all(d.startswith("1 row(s)") for _, _, d in found)


def test_zero_frame_episode_and_row_count(healthy: Path, tmp_path: Path) -> None:
    ds = copy_dataset(healthy, tmp_path / "rows")
    path = data_file(ds)
    table = pq.read_table(path)
    ep = table.column("episode_index")
    keep = pc.and_(pc.not_equal(ep, 2), pc.invert(pc.and_(pc.equal(ep, 5), pc.equal(table.column("frame_index"), 0))))
    rewrite_parquet(path, table.filter(keep))
    found = _issues(ds)
    assert [(e, c) for e, c, _ in found] == [(2, "zero_frames"), (5, "frame_count")]
    assert "metadata length 10, 9 parquet rows" in found[1][2]


def test_video_frame_count_mismatch(healthy: Path, tmp_path: Path) -> None:
    """Drop the last packet of the front camera's mp4: only the last episode loses a video frame."""
    ds = copy_dataset(healthy, tmp_path / "video")
    path = ds / "videos/observation.images.front/chunk-000/file-000.mp4"
    full = len(count_packets(path))
    tmp = path.with_name("short.mp4")
    with av.open(str(path)) as src, av.open(str(tmp), "w", format="mp4") as dst:
        stream_in = src.streams.video[0]
        stream_out = dst.add_stream_from_template(stream_in)
        packets = [p for p in src.demux(stream_in) if p.dts is not None]
        last = max(p.pts for p in packets)  # type: ignore[type-var]
        for p in packets:
            if p.pts != last:
                p.stream = stream_out
                dst.mux(p)
    tmp.replace(path)
    assert len(count_packets(path)) == full - 1
    found = _issues(ds)
    assert [(e, c) for e, c, _ in found] == [(7, "video_frames")]
    assert "observation.images.front: " in found[0][2] and "parquet rows" in found[0][2]


def test_truncated_parquet_is_a_one_line_error(healthy: Path, tmp_path: Path) -> None:
    ds = copy_dataset(healthy, tmp_path / "truncated")
    path = data_file(ds)
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])
    proc = run_cli("stats", str(ds))
    assert proc.returncode == 2
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"error: {path}: unreadable parquet"), proc.stderr
