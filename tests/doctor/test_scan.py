"""`doctor`'s scan of what the frames mean (`metrics.signals`, `doctor.check_scan`), with known answers: a
quaternion sign flip injected at frame k, an angle wrapped at frame k, timestamps at another rate than declared
and a video longer than its rows are each one warning naming the column, the episode and frame k."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from openral_data.doctor.findings import (
    SCAN_ANGLE_WRAP,
    SCAN_QUATERNION_FLIP,
    SCAN_TIMESTAMP_RATE,
    SCAN_VIDEO_LENGTH,
)
from openral_data.metrics.signals import angle_wraps, quaternion_flips, rate_mismatch
from tests.support.inproc import run_inproc
from tests.support.legacy_v2 import write_v2

NAMES = ["eef_x", "eef_qx", "eef_qy", "eef_qz", "eef_qw", "yaw"]
N = 12  # frames of episode 1


def _rotation(n: int) -> np.ndarray[Any, Any]:
    """A slow rotation about z (w >= 0 throughout): quaternions (x, y, z, w) of angles 0.1 t."""
    a = 0.1 * np.arange(n) / 2
    return np.stack([np.zeros(n), np.zeros(n), np.sin(a), np.cos(a)], axis=1)


def test_a_flip_at_frame_k_is_found_there_and_a_rotation_is_not() -> None:
    q = _rotation(N)
    values = np.concatenate([np.zeros((N, 1)), q, np.zeros((N, 1))], axis=1)
    assert quaternion_flips(values, "observation.state", NAMES) == []
    values[7:10, 1:5] *= -1  # frames 7..9 written as -q: flips at 7 and back at 10
    (signal,) = quaternion_flips(values, "observation.state", NAMES)
    assert signal.columns == ("observation.state[eef_qx..w]",) and signal.frames == (7, 10)
    # a feature whose key says quat is one quaternion whatever its names; order does not matter
    (quat,) = quaternion_flips(values[:, [4, 2, 1, 3]], "observation.quat", ["a", "b", "c", "d"])
    assert quat.frames == (7, 10)


def test_an_angle_wrapped_at_frame_k() -> None:
    yaw = np.linspace(2.8, 3.6, N)  # crosses π between frames 4 and 5
    values = np.stack([np.zeros(N), yaw], axis=1)
    assert angle_wraps(values, "state", ["x", "base_yaw"]) == []
    wrapped = values.copy()
    wrapped[:, 1] = (yaw + math.pi) % (2 * math.pi) - math.pi
    (signal,) = angle_wraps(wrapped, "state", ["x", "base_yaw"])
    assert signal.columns == ("state[base_yaw]",) and signal.frames == (5,)
    assert angle_wraps(wrapped, "state", ["x", "gripper_width"]) == []  # not an angle-like name


def test_timestamps_at_another_rate() -> None:
    assert rate_mismatch(np.arange(N) / 10, 10) is None
    signal = rate_mismatch(np.arange(N) / 15, 10)  # 15 fps data declared 10 fps
    assert signal is not None and signal.frames[0] == 2 and "15 fps" in signal.detail


def _with_pose(root: Path, edit: Any) -> None:
    """observation.state of every episode: [x, qx, qy, qz, qw, yaw] (a rotation, yaw rising through π)."""
    info = json.loads((root / "meta/info.json").read_text())
    info["features"]["observation.state"].update(shape=[6], names=NAMES)
    (root / "meta/info.json").write_text(json.dumps(info, indent=4))
    for e, path in enumerate(sorted(root.glob("data/*/*.parquet"))):
        table = pq.read_table(path)
        n = table.num_rows
        state = np.concatenate([np.zeros((n, 1)), _rotation(n), np.linspace(2.8, 3.0, n)[:, None]], axis=1)
        table = edit(e, table, state)
        i = table.schema.get_field_index("observation.state")
        column = pa.array(state.astype(np.float32).tolist(), pa.list_(pa.float32(), 6))
        pq.write_table(table.set_column(i, "observation.state", column).replace_schema_metadata(None), path)


def _scan_findings(root: Path) -> list[dict[str, Any]]:
    proc = run_inproc("doctor", str(root), "--json")
    assert proc.returncode in (0, 1) and "Traceback" not in proc.stderr, proc.stderr
    return [f for f in json.loads(proc.stdout)["findings"] if f["code"].startswith("scan.")]


def test_doctor_names_the_column_episode_and_frame(tmp_path: Path) -> None:
    root = write_v2(tmp_path / "ds", lengths=(6, N, 4))
    _with_pose(root, lambda e, table, state: table)
    assert _scan_findings(root) == []  # a clean dataset: no scan warning

    def inject(e: int, table: pa.Table, state: np.ndarray[Any, Any]) -> pa.Table:
        if e == 1:
            state[7:, 1:5] *= -1  # q -> -q from frame 7 on
            state[9:, 5] -= 2 * math.pi  # yaw wrapped at frame 9
            ts = table.schema.get_field_index("timestamp")
            table = table.set_column(ts, table.schema.field(ts), pa.array(np.arange(N) / 15, pa.float32()))
        return table

    _with_pose(root, inject)
    found = {f["code"]: f for f in _scan_findings(root)}
    assert set(found) == {SCAN_QUATERNION_FLIP, SCAN_ANGLE_WRAP, SCAN_TIMESTAMP_RATE}
    assert all(f["severity"] == "warning" and f["where"].endswith("episode_000001.parquet") for f in found.values())
    flip = found[SCAN_QUATERNION_FLIP]["message"]
    assert flip.startswith("episode 1: observation.state[eef_qx..w]: quaternion sign flip at frame(s) 7;"), flip
    assert "episode 1: observation.state[yaw]: angle wraps by 2π at frame(s) 9;" in found[SCAN_ANGLE_WRAP]["message"]
    assert "timestamp: timestamps off the declared fps at frame(s) 2," in found[SCAN_TIMESTAMP_RATE]["message"]


@pytest.mark.parametrize("drop", [2])
def test_a_video_longer_than_its_rows(tmp_path: Path, drop: int) -> None:
    """Episode 1's rows cut short (its mp4 keeps every frame): lerobot loads it, the scan says so."""
    root = write_v2(tmp_path / "ds")
    path = root / "data/chunk-000/episode_000001.parquet"
    table = pq.read_table(path)
    pq.write_table(table.slice(0, table.num_rows - drop), path)
    rows = [json.loads(line) for line in (root / "meta/episodes.jsonl").read_text().splitlines()]
    rows[1]["length"] -= drop
    (root / "meta/episodes.jsonl").write_text("".join(json.dumps(r) + "\n" for r in rows))
    info = json.loads((root / "meta/info.json").read_text())
    info["total_frames"] -= drop
    (root / "meta/info.json").write_text(json.dumps(info))
    found = [f for f in _scan_findings(root) if f["code"] == SCAN_VIDEO_LENGTH]
    assert [f["message"] for f in found] == ["episode 1: 8 video frame(s) for 6 row(s)"]
