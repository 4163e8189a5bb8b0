"""Episode quality measures against hand-built episodes with known answers (tests/support/quality.py), a
property sweep that a moving, clean episode raises no flag, and lerobot-written datasets."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
import pyarrow.compute as pc
import pyarrow.parquet as pq
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from openral_data.formats.lerobot_v3.features import ACTION, STATE
from openral_data.metrics.quality import DEFAULT, Quality, quality_of
from openral_data.metrics.quality.camera import camera_quality
from openral_data.metrics.quality.episode import FINDINGS, episode_motion
from openral_data.metrics.quality.table import FLAGS, raised
from openral_data.metrics.sources import open_dataset
from tests.support import quality as q
from tests.support.lerobot_written import digest, write_lerobot_dataset
from tests.support.metrics import data_file, rewrite_parquet

N = 60
IDLE_HEAD = 7  # frames 0..6 hold still, frame 7 moves
IDLE_TAIL_FROM = 50  # frames 50..59 hold frame 50's values: 9 idle frames (frame 50 itself moved)
FROZEN_FROM = 25  # state j1 holds from frame 25 while the others move: a stale reading
UNUSED_FROM = 40  # action a0 holds from frame 40: a scripted expert done with it, no fault ("constant")
CLIP_AT = 1.1  # the clipped episode's state j0 is a sinusoid of amplitude 2 cut at 1.1 (its dataset max): flat tops
BLACK = (20, 35)  # camera frames 20..34 black
GAP_AT = 30  # frames 30.. stamped half a second late: one gap of 6 periods
EPISODES = ["clean", "clean2", "idle_head", "idle_tail", "frozen", "black", "chatter", "gap", "jerky", "clipped"]


def _episodes() -> list[q.Episode]:
    eps = {name: q.moving(N, seed) for seed, name in enumerate(EPISODES)}
    idle = eps["idle_head"]
    idle.state[:IDLE_HEAD] = idle.state[IDLE_HEAD - 1]
    idle.action[:IDLE_HEAD] = idle.action[IDLE_HEAD - 1]
    tail = eps["idle_tail"]
    tail.state[IDLE_TAIL_FROM:] = tail.state[IDLE_TAIL_FROM]
    tail.action[IDLE_TAIL_FROM:] = tail.action[IDLE_TAIL_FROM]
    eps["frozen"].state[FROZEN_FROM:, 1] = eps["frozen"].state[FROZEN_FROM, 1]
    eps["frozen"].action[UNUSED_FROM:, 0] = eps["frozen"].action[UNUSED_FROM, 0]
    clipped = eps["clipped"].state
    clipped[:, 0] = np.minimum(2 * clipped[:, 0], CLIP_AT)
    eps["black"].images[BLACK[0] : BLACK[1]] = 0
    eps["chatter"].action[:, 2] = (np.arange(N) // 2) % 2  # open/close every 2 frames: 29 toggles in 6 s
    noise = np.random.default_rng(0).normal(0, 0.3, (N, 2)).astype(np.float32)
    eps["jerky"].action[:, :2] += noise
    return [eps[name] for name in EPISODES]


def _stamp_gap(root: Path, episode: int) -> None:
    path = data_file(root)
    table = pq.read_table(path)
    late = pc.and_(pc.equal(table["episode_index"], episode), pc.greater_equal(table["frame_index"], GAP_AT))
    stamps = pc.if_else(late, pc.add(table["timestamp"], pa.scalar(0.5, pa.float32())), table["timestamp"])
    rewrite_parquet(path, table.set_column(table.schema.get_field_index("timestamp"), "timestamp", stamps))


@pytest.fixture(scope="module")
def built(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Quality]:
    root = q.write(tmp_path_factory.mktemp("quality") / "ds", _episodes())
    _stamp_gap(root, EPISODES.index("gap"))
    return root, quality_of(open_dataset(root), stride=1)


def _row(built: tuple[Path, Quality], name: str) -> dict[str, Any]:
    rows = built[1].table.to_pylist()
    assert [r["episode_index"] for r in rows] == list(range(len(EPISODES)))
    return dict(rows[EPISODES.index(name)])


def test_clean_episodes_raise_no_flag(built: tuple[Path, Quality]) -> None:
    for name in ("clean", "clean2"):
        row = _row(built, name)
        assert row["flags"] == [] and not row["flagged"], (name, row)
        assert row["idle_head"] == row["idle_tail"] == 0 and row["findings"] == []
        assert row["gripper_toggles"] == 2 and row["timestamp_gaps"] == 0


def test_idle_head_and_tail_in_frames(built: tuple[Path, Quality]) -> None:
    head, tail = _row(built, "idle_head"), _row(built, "idle_tail")
    assert (head["idle_head"], head["idle_tail"]) == (IDLE_HEAD, 0)
    assert head["idle_fraction"] == pytest.approx(IDLE_HEAD / N)
    assert (tail["idle_head"], tail["idle_tail"]) == (0, N - 1 - IDLE_TAIL_FROM)
    assert "idle" not in head["flags"]  # under half the episode


def test_idle_frames_per_frame(built: tuple[Path, Quality]) -> None:
    frames = pq.read_table(built[1].paths.frames).to_pylist()
    e = EPISODES.index("idle_head")
    idle = [r["idle"] for r in sorted(frames, key=lambda r: r["frame_index"]) if r["episode_index"] == e]
    assert idle == [True] * IDLE_HEAD + [False] * (N - IDLE_HEAD)
    assert len(frames) == N * len(EPISODES)


def _findings(built: tuple[Path, Quality], name: str) -> list[tuple[Any, ...]]:
    """(check, subject, start_frame, end_frame, flag) of one episode's findings."""
    rows = pq.read_table(built[1].paths.findings).to_pylist()
    e = EPISODES.index(name)
    return [
        (r["check"], r["subject"], r["start_frame"], r["end_frame"], r["flag"]) for r in rows if r["episode_index"] == e
    ]


def test_frozen_state_and_an_unused_action_told_apart(built: tuple[Path, Quality]) -> None:
    """A state dimension held bit for bit while the others move is frozen, from its frame to the end; an action
    dimension held to the end is only `constant` (informational): it raises no flag."""
    row = _row(built, "frozen")
    assert row["flags"] == ["frozen"] and row["findings"] == [f"frozen:{STATE}[j1]"]
    assert sorted(_findings(built, "frozen")) == [
        ("constant", f"{ACTION}[a0]", UNUSED_FROM, N - 1, False),
        ("constant", f"{STATE}[j1]", FROZEN_FROM, N - 1, False),
        ("frozen", f"{STATE}[j1]", FROZEN_FROM, N - 1, True),
    ]


def test_clipped_flat_top_in_frames(built: tuple[Path, Quality]) -> None:
    j0 = q.moving(N, EPISODES.index("clipped")).state[:, 0]
    top = np.flatnonzero(2 * j0 >= CLIP_AT)
    spans = [(int(s[0]), int(s[-1])) for s in np.split(top, np.flatnonzero(np.diff(top) > 1) + 1)]
    spans = [(a, b) for a, b in spans if a > 0 and b < N - 1]  # a flat top is entered and left in the episode
    row = _row(built, "clipped")
    share = sum(b - a + 1 for a, b in spans) / N
    assert row["flags"] == ["clipped"] and row["state_clip_fraction"] == pytest.approx(share)
    clipped = [f for f in _findings(built, "clipped") if f[0] == "clipped"]
    assert spans and clipped == [("clipped", f"{STATE}[j0]", a, b, True) for a, b in spans]


def test_black_camera_span(built: tuple[Path, Quality]) -> None:
    row = _row(built, "black")
    assert row["camera_black_fraction"] == pytest.approx((BLACK[1] - BLACK[0]) / N)
    assert row["camera_first_black"] == BLACK[0]
    assert row["flags"] == ["camera_black"] and row["camera_flags"] == ["observation.images.cam:black"]
    assert _findings(built, "black") == [("camera_black", "observation.images.cam", BLACK[0], BLACK[1] - 1, True)]
    samples = pq.read_table(built[1].paths.camera_frames).to_pylist()
    e = EPISODES.index("black")
    black = sorted(s["frame_index"] for s in samples if s["episode_index"] == e and s["black"])
    assert black == list(range(*BLACK))


def test_chattering_gripper(built: tuple[Path, Quality]) -> None:
    row = _row(built, "chatter")
    assert row["gripper_toggles"] == 29 and row["gripper_toggles_per_s"] == pytest.approx(29 / (N / q.FPS))
    assert row["flags"] == ["chatter"]
    assert _findings(built, "chatter") == [("chatter", f"{ACTION}[gripper]", 2, N - 2, True)]


def test_timestamp_gap(built: tuple[Path, Quality]) -> None:
    row = _row(built, "gap")
    assert row["timestamp_gaps"] == 1 and row["flags"] == ["gap"]
    assert row["timestamp_jitter"] < DEFAULT.jitter_flag
    assert _findings(built, "gap") == [("gap", "timestamp", GAP_AT, GAP_AT, True)]


def test_jerky_demonstration(built: tuple[Path, Quality]) -> None:
    row = _row(built, "jerky")
    assert row["jerk_reversal_share"] >= DEFAULT.jerk_reversal_share > _row(built, "clean")["jerk_reversal_share"]
    assert row["flags"] == ["jerky"]
    found = _findings(built, "jerky")
    assert {f[1] for f in found} <= {f"{ACTION}[a0]", f"{ACTION}[a1]"} and all(f[0] == "jerky" for f in found)
    assert min(f[2] for f in found) == 0 and max(f[3] for f in found) >= N - 2


def test_only_the_planted_fault_is_flagged(built: tuple[Path, Quality]) -> None:
    flagged = {r["episode_index"]: r["flags"] for r in built[1].table.to_pylist() if r["flagged"]}
    planted = {"frozen": "frozen", "black": "camera_black", "chatter": "chatter", "gap": "gap", "jerky": "jerky"}
    planted["clipped"] = "clipped"
    assert flagged == {EPISODES.index(name): [flag] for name, flag in planted.items()}


@settings(max_examples=40, deadline=None)
@given(
    n=st.integers(8, 240),
    fps=st.sampled_from([10, 15, 30, 50]),
    period_s=st.floats(1.5, 10.0),
    seed=st.integers(0, 2**16),
)
def test_a_moving_clean_episode_raises_no_flag(n: int, fps: int, period_s: float, seed: int) -> None:
    """Every dimension a sinusoid of its own phase (so some dimension always moves), the gripper closing and
    opening once, stamps on time, the camera changing texture every frame: no flag, whatever the length, rate
    or speed. Measured in memory (the same functions the dataset pass calls)."""
    ep = q.moving(n, seed, period_s=period_s * fps / q.FPS)  # a period of period_s seconds at `fps`
    arrays = {STATE: ep.state.astype(np.float64), ACTION: ep.action.astype(np.float64)}
    ranges = {k: (x.min(axis=0), x.max(axis=0)) for k, x in arrays.items()}
    ds = _FakeSource(fps)
    row, _ = episode_motion(ds, arrays, np.arange(n) / fps, ranges, DEFAULT)  # type: ignore[arg-type]
    cam = camera_quality(iter(ep.images), 1, DEFAULT)  # stride 1: every frame is a sample
    found = [f for f in row[FINDINGS] + cam.findings("cam", DEFAULT, 1, n) if f.flag]
    flags = raised(found)
    assert set(flags) == set(FLAGS) and not any(flags.values()) and not found, (row, found)


class _FakeSource:
    """What `episode_motion` asks of a dataset: its fps, dimension names and robot (none: no manifest)."""

    def __init__(self, fps: int) -> None:
        self.fps = fps
        self.robot = None

    def dim_names(self, key: str) -> list[str]:
        return list(q.SCHEMA.state_names if key == STATE else q.SCHEMA.action_names)


def test_lerobot_written_dataset_cached_outside_it(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """lerobot's own dataset: measured like ours, its folder left byte-identical (the table goes to the user
    cache, XDG_CACHE_HOME)."""
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    root = tmp_path / "lerobot"
    write_lerobot_dataset(root, with_success=True)
    before = digest(root)
    got = quality_of(open_dataset(root))
    assert got.computed and got.table.num_rows == 3
    assert got.paths.episodes.is_relative_to(tmp_path / "cache" / "openral-data" / "quality")
    assert digest(root) == before and not (root / ".openral").exists()
    # state [t, e, 0.5] and action [0.1 t, -0.1 t] move every frame; the camera is one flat colour per frame
    assert [r["idle_fraction"] for r in got.table.to_pylist()] == [0.0, 0.0, 0.0]
    assert not quality_of(open_dataset(root)).computed
