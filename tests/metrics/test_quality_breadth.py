"""The breadth checks, each on a small hand-built episode (through our writer where the writer can carry the
fault): the right check, subject and frames, and nothing on the clean episode."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from openral_data.formats.lerobot_v3.features import ACTION, STATE
from openral_data.metrics.quality import DEFAULT, quality_of, rows, views
from openral_data.metrics.quality.alignment import alignment, target_steps
from openral_data.metrics.quality.breadth import angle_wraps, quaternions, task_text
from openral_data.metrics.quality.camera import camera_quality, stalled
from openral_data.metrics.quality.dims import bursts, frozen_state, toggle_frames
from openral_data.metrics.sources import open_dataset
from tests.support import quality as q
from tests.support.metrics import data_file, rewrite_parquet

N = 40
NAN = (10, 12)  # episode 1: action a1 NaN over frames 10..12
JUMP = (20, 25)  # episode 2: state j0 jumps 5.0 up at frame 20 and back at 25


def _episodes() -> list[q.Episode]:
    eps = [q.moving(N, seed) for seed in range(5)] + [q.moving(5 * N, 5)]
    eps[2].state[JUMP[0] : JUMP[1], 0] += 5.0
    eps[3].state[:, 2] = eps[3].state[:, 1]
    eps[4] = q.Episode(eps[0].state.copy(), eps[0].action.copy(), q.textured(N, 99))
    return eps


def _nan_actions(root: Path) -> None:
    """NaN in episode 1's action a1 over frames `NAN` (our writer refuses them: written into the parquet)."""
    path = data_file(root)
    table = pq.read_table(path)
    action = np.array(table[ACTION].to_pylist(), dtype=np.float32)
    frame = table["frame_index"].to_numpy()
    hit = (table["episode_index"].to_numpy() == 1) & (frame >= NAN[0]) & (frame <= NAN[1])
    action[hit, 1] = np.nan
    column = pa.array([row.tolist() for row in action], type=table.schema.field(ACTION).type)
    rewrite_parquet(path, table.set_column(table.schema.get_field_index(ACTION), ACTION, column))


@pytest.fixture(scope="module")
def found(tmp_path_factory: pytest.TempPathFactory) -> dict[int, list[tuple[Any, ...]]]:
    root = q.write(tmp_path_factory.mktemp("breadth") / "ds", _episodes())
    _nan_actions(root)
    got = quality_of(open_dataset(root))
    out: dict[int, list[tuple[Any, ...]]] = {e: [] for e in range(6)}
    for f in pq.read_table(got.paths.findings).to_pylist():
        if f["flag"]:
            out[f["episode_index"]].append((f["check"], f["subject"], f["start_frame"], f["end_frame"]))
    flags = {r["episode_index"]: r["flags"] for r in got.table.to_pylist()}
    assert {e: sorted({c for c, *_ in fs}) for e, fs in out.items()} == {e: sorted(v) for e, v in flags.items()}
    return out


def test_each_fault_found_with_its_subject_and_frames(found: dict[int, list[tuple[Any, ...]]]) -> None:
    assert found[0] == []  # the clean one
    assert found[1] == [("non_finite", f"{ACTION}[a1]", *NAN)]
    assert found[2] == [("teleport", f"{STATE}[j0]", JUMP[0], JUMP[0]), ("teleport", f"{STATE}[j0]", JUMP[1], JUMP[1])]
    assert found[3] == [("duplicated", f"{STATE}[j2]", 0, N - 1)]
    assert found[4] == [("duplicate_episode", "episode", None, None)]  # episode 0's state and action again
    assert found[5] == [("length_outlier", "episode", 0, 5 * N - 1)]  # 5 times the median length


def test_quaternion_flip_and_norm_and_angle_wrap_frames() -> None:
    n = 30
    angle = np.linspace(0, 0.9, n)
    quat = np.stack([np.cos(angle / 2), np.zeros(n), np.zeros(n), np.sin(angle / 2)], axis=1)  # w, x, y, z
    quat[12:] *= -1  # the same orientations, the other sign, from frame 12
    quat[20:23] *= 1.5  # norms of 1.5 over frames 20..22
    yaw = np.linspace(3.0, 3.5, n)
    yaw[15:] -= 2 * math.pi  # wrapped into (-pi, pi] at frame 15
    x = np.concatenate([quat, yaw[:, None]], axis=1)
    names = ["eef_qw", "eef_qx", "eef_qy", "eef_qz", "base_yaw"]
    got = [(f.check, f.subject, f.start_frame, f.end_frame) for f in quaternions(x, names, STATE, DEFAULT)]
    assert got == [
        ("quat_flip", f"{STATE}[eef_qx..w]", 12, 12),
        ("quat_norm", f"{STATE}[eef_qx..w]", 20, 22),
    ]
    wraps = [(f.check, f.subject, f.start_frame) for f in angle_wraps(x, names, STATE)]
    assert wraps == [("angle_wrap", f"{STATE}[base_yaw]", 15)]
    clean = np.concatenate([np.abs(quat) / np.linalg.norm(quat, axis=1, keepdims=True), angle[:, None]], axis=1)
    assert quaternions(clean, names, STATE, DEFAULT) == [] and angle_wraps(clean, names, STATE) == []


def test_task_text() -> None:
    assert [f.detail.split(":")[0] for f in task_text(["", " TODO ", "<task>", "pick\x00 the cube", "n/a"])] == [
        "empty",
        "placeholder",
        "placeholder",
        "control characters",
        "placeholder",
    ]
    assert task_text(["pick up the red cube", "Put the bowl on the plate."]) == []


def test_a_camera_still_while_the_other_moves() -> None:
    """Camera `b` repeats frame 10's picture over frames 10..17 while `a` keeps changing: `camera_stalled` on
    `b` only; both still at once (the robot resting in a static scene) is not it."""
    a, b = q.textured(N, 1), q.textured(N, 2)
    b[10:18] = b[10]
    cams = {"a": camera_quality(iter(a), 1, DEFAULT), "b": camera_quality(iter(b), 1, DEFAULT)}
    got = [(f.check, f.subject, f.start_frame, f.end_frame) for f in stalled(cams, DEFAULT, 1, N)]
    assert got == [("camera_stalled", "b", 11, 17)]  # frame 10 itself still differs from frame 9
    both = q.textured(N, 3)
    both[10:18] = both[10]
    still = {"a": camera_quality(iter(both), 1, DEFAULT), "b": camera_quality(iter(both.copy()), 1, DEFAULT)}
    assert stalled(still, DEFAULT, 1, N) == []


def test_a_turned_camera_whose_scene_varies_between_episodes_is_found() -> None:
    """A camera whose mean picture changes from episode to episode (objects placed anew each time, as a table
    filmed from above) matches the other episodes' median only 0.25-0.5 even the right way up: the turned
    episode is still `camera_flipped` over its frames, the others are not, nor are episodes of noise."""
    rng = np.random.default_rng(0)
    ramp = np.repeat(np.linspace(180, 80, 16)[:, None], 16, 1)
    thumbs = {}
    for e in range(5):
        objects = np.kron(rng.normal(0, 50, (4, 4)), np.ones((4, 4)))  # a coarse layout of its own per episode
        thumbs[e] = (ramp + objects).astype(np.float32)
    thumbs[3] = thumbs[3][::-1, ::-1].copy()
    ref = views.standard(np.median(np.stack([thumbs[e] for e in (0, 1, 2, 4)]), axis=0))
    assert 0.25 <= float(views.standard(thumbs[3][::-1, ::-1]) @ ref) < 0.5  # the regime: a weak match
    got = views.flipped(thumbs, "observation.images.top", dict.fromkeys(thumbs, 40), DEFAULT.flip_margin)
    assert list(got) == [3]
    assert [(f.check, f.subject, f.start_frame, f.end_frame) for f in got[3]] == [
        ("camera_flipped", "observation.images.top", 0, 39)
    ]
    noise = {e: rng.normal(128, 40, (16, 16)).astype(np.float32) for e in range(8)}
    assert views.flipped(noise, "cam", dict.fromkeys(noise, 40), DEFAULT.flip_margin) == {}


def _pictures(frames: np.ndarray) -> np.ndarray:
    """An episode's `views` pictures from its frames (n, H, W) of luma, measured as `quality` measures them."""
    rgb = np.repeat(np.clip(frames, 0, 255).astype(np.uint8)[..., None], 3, axis=3)
    thumb = camera_quality(iter(rgb), 1, DEFAULT).thumb
    assert thumb is not None
    return thumb


def test_a_turned_camera_is_found_by_its_edges_or_where_it_moves() -> None:
    """Pictures 86 px square (not a multiple of the 16 px thumbnail: turned 180°, the thumbnail is the thumbnail
    turned). Two scenes whose mean luma differs from episode to episode and tells nothing: a smooth lighting of its
    own per episode with a thin frame drawn top left (only its edges tell up from down), and a table textured anew
    per episode, still, with the arm moving across its top (only where the picture moves tells). Episode 3 turned
    180° is `camera_flipped` (before: nothing, only the mean luma was compared), no other episode."""
    rng = np.random.default_rng(1)
    side = 86
    yy, xx = np.mgrid[0:side, 0:side].astype(np.float32)
    picture = rng.normal(128, 40, (side, side)).astype(np.float32)
    turned = views.thumbnail(picture[::-1, ::-1])
    assert np.allclose(turned, views.thumbnail(picture)[::-1, ::-1])
    lit, moved = {}, {}
    for e in range(5):
        light = 128 + 60 * np.sin(rng.uniform(0.02, 0.06) * xx + rng.uniform(0.02, 0.06) * yy + rng.uniform(0, 6))
        light[[8, 30], 8:50] = light[8:31, [8, 50]] = 250  # the frame, 1 px wide
        lit[e] = np.repeat(light[None], 6, axis=0)
        table = np.repeat(np.kron(rng.integers(40, 216, (11, 11)), np.ones((8, 8)))[None, :side, :side], 12, axis=0)
        for t in range(12):  # the arm: a dark block crossing the top
            table[t, 4:20, 6 * t + 2 : 6 * t + 14] = 20
        moved[e] = table
    for scene, view in ((lit, "edges"), (moved, "motion")):
        scene[3] = scene[3][:, ::-1, ::-1]
        thumbs = {e: _pictures(frames) for e, frames in scene.items()}
        got = views.flipped(thumbs, "cam", dict.fromkeys(thumbs, 12), DEFAULT.flip_margin)
        assert list(got) == [3], (view, got)
        assert got[3][0].detail.startswith(f"its {view}") and (got[3][0].start_frame, got[3][0].end_frame) == (0, 11)
        means = {e: t[0] for e, t in thumbs.items()}  # the mean luma alone does not tell
        assert views.flipped(means, "cam", dict.fromkeys(means, 12), DEFAULT.flip_margin) == {}, view


def test_a_flat_top_of_a_reading_that_holds_most_of_the_time_is_not_clipped() -> None:
    """Two state dimensions rising to a first peak, turning back, then to a higher second one, each commanded by
    an action moving all along, each held 15 frames at the first peak (entered and left from below, under the
    dataset's max). The arm joint's reading changes every other frame: its flat top is `clipped` there. The
    finger's reading updates every 5 frames by a count (a slow sensor: a staircase, held on 80 % of its
    frames, as the G1's fingers are): its flat top is one more step of it, no clip (before: clipped)."""
    n = 90
    t = np.arange(n, dtype=np.float64)
    wave = np.sin(2 * np.pi * t / 60) + (t > 45) * np.sin(np.pi * (t - 45) / 45) * 0.6  # peaks ~1 at 15, 1.5 at 67
    first = t < 45
    joint = np.where(first, np.minimum(wave, 0.7), wave)  # held over frames 8..22
    finger = np.round(wave[(t // 5 * 5).astype(int)] / 0.05) * 0.05  # held 5 frames, counts of 0.05
    finger = np.where(first, np.minimum(finger, 0.7), finger)  # held over frames 10..24
    x = np.stack([joint, finger], axis=1)
    commands = {0: wave * 0.9, 1: wave * 0.9}
    limits = (x.min(axis=0), x.max(axis=0))
    varies = np.ones(2, dtype=bool)
    got = frozen_state(x, limits, ["joint", "finger"], varies, commands, (12, 10), STATE)
    clipped = [(f.subject, f.start_frame, f.end_frame) for f in got if f.check == "clipped"]
    assert clipped == [(f"{STATE}[joint]", 8, 22)], got


def test_a_follower_catching_up_with_its_position_target_is_no_teleport() -> None:
    """A joint that barely moves (a range of 0.0035 rad) creeping by 0.00002 a frame steps 0.0004 at frame 30, 0.11
    of its range and 20 times its neighbours, while its position target (`action_2` pairs with
    `observation.state_2`) moves 0.0015 a frame around it, as the G1 fixture's arm does: the follower catching up,
    no teleport (before: a teleport). The same step while the target holds still is a teleport, at frame 30."""
    t = np.arange(60)
    still = -0.5600 + 0.00002 * t + 0.0001 * np.maximum(t - 40, 0)  # the rest of its range reached slowly
    joint = still + 0.0004 * (t >= 30)
    moving = still + 0.0015 * np.r_[[0] * 24, [0, 1, 2, 3, 4, 5, 4, 3, 2, 1], [0] * 26]  # 0.0015 a frame about it
    names = (["action_2"], ["observation.state_2"])
    lo, hi = joint.min(), joint.max()
    z = ((joint - lo) / (hi - lo))[:, None]
    for action, found in ((moving, []), (still, [30])):
        steps = target_steps(action[:, None], names, [0], np.array([hi - lo]))
        got = rows.teleports(z, names[1], STATE, DEFAULT, set(), steps)
        assert [f.start_frame for f in got] == found, got


def test_an_angle_wrap_of_a_manifest_joint_and_in_degrees() -> None:
    """`shoulder_pan` is no angle by its name: wrapped at ±180° it is found only as the manifest's revolute joint
    (`also`), at the frame it jumps by 360."""
    pan = np.linspace(150.0, 210.0, 20)
    pan[pan > 180] -= 360  # written in (-180, 180]: the jump at frame 10
    x = np.stack([pan, np.linspace(0.0, 1.0, 20)], axis=1)
    assert angle_wraps(x, ["shoulder_pan", "x"], STATE) == []
    got = [(f.check, f.subject, f.start_frame) for f in angle_wraps(x, ["shoulder_pan", "x"], STATE, frozenset({0}))]
    assert got == [("angle_wrap", f"{STATE}[shoulder_pan]", 10)]


def test_a_teleport_along_the_motion_is_no_frame_drop() -> None:
    """Three dimensions moving steadily, the first the fastest: frames lost carry all three further by one
    factor (`frame_drop`); the first one alone jumping ahead along its motion is a `teleport`, not a drop."""
    n, at = 40, 20
    z = np.cumsum(np.tile([0.02, 0.003, 0.003], (n, 1)), axis=0)
    late = np.zeros(n - 1, dtype=bool)
    dropped = np.concatenate([z[:at], z[at + 5 :]])  # 5 frames lost before frame `at`
    assert [f for f, _ in rows.frame_drops(dropped, late[: len(dropped) - 1], DEFAULT)] == [at]
    jumped = z.copy()
    jumped[at:, 0] += 0.1
    assert rows.frame_drops(jumped, late, DEFAULT) == []
    found = rows.teleports(jumped, ["j0", "j1", "j2"], STATE, DEFAULT, set())
    got = [(f.check, f.subject, f.start_frame) for f in found]
    assert got == [("teleport", f"{STATE}[j0]", at)]


def test_two_swapped_actions_of_a_diagonal_motion() -> None:
    """x and y move together (correlated 0.8), z apart: with their velocity commands swapped each still follows
    its own state 0.8 but the other's better: `action_swap` on both; the clean episode raises nothing."""
    rng = np.random.default_rng(0)
    smooth = np.array([np.convolve(rng.normal(size=300), np.ones(15) / 15, "same") for _ in range(3)]).T
    v = np.stack([smooth[:, 0], 0.8 * smooth[:, 0] + 0.6 * smooth[:, 1], smooth[:, 2]], axis=1)
    state = np.cumsum(v, axis=0)
    names = (["delta_x", "delta_y", "delta_z"], ["eef_x", "eef_y", "eef_z"])
    assert alignment(v[:-1], state[1:], names, DEFAULT) == []
    swapped = v[:, [1, 0, 2]]
    got = [(f.check, f.subject) for f in alignment(swapped[:-1], state[1:], names, DEFAULT)]
    assert got == [("action_swap", "action[delta_x]"), ("action_swap", "action[delta_y]")]


def test_a_chatter_burst_is_placed_at_its_frames() -> None:
    """A gripper opening and closing every 20 frames, and toggling every frame over 60..79: the burst's span (a
    toggle within half a second of the one before at 10 fps), not the first to the last toggle."""
    grip = ((np.arange(150) // 20) % 2).astype(np.float64)
    grip[60:80] = np.arange(20) % 2
    frames = toggle_frames(grip, 0.0, 1.0)
    assert bursts(frames, 5) == [(min(f for f in frames if f >= 60), max(f for f in frames if f < 81))]
    assert bursts(frames, 5)[0][0] in (60, 61) and bursts(frames, 5)[0][1] in (79, 80)
