"""`quality` finds each kind of injected data fault at its frames, and nothing in the clean episode it came from.

One clean moving episode (tests/support/quality.py: three joints, an action with a gripper closing once, a
textured camera, 60 frames at 10 fps), read back with our reader and written again through our writer as the
clean dataset; then, per fault kind, a dataset holding that episode with the fault injected
(tests/support/data_faults.py). The fault must raise a finding of the check expected for its kind, about the
injected dimension or camera, with frames within 2 of the truth (benchmarks/calibrate_quality.py measures the
same over the whole labelled corpus).
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from openral_data.formats.lerobot_v3.features import STATE
from openral_data.metrics.quality import DEFAULT, rows
from openral_data.metrics.quality.thresholds import for_kind
from tests.support import data_faults as df
from tests.support import quality as q

N = 60
# every kind the engine finds on this episode; the others (named in docs/stats.md, "Calibration") are not
# detected yet, or do not apply to it (a quaternion, a second camera)
DETECTED = (
    "idle_head",
    "idle_tail",
    "frozen_camera",
    "black_camera",
    "blur",
    "dropped_frames",
    "duplicated_frames",
    "timestamp_gap",
    "gripper_chatter",
    "clipping",
    "nan",
    "teleport",
)


@pytest.fixture(scope="module")
def clean(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, df.Clean]:
    root = tmp_path_factory.mktemp("faults")
    source = q.write(root / "source", [q.moving(N, seed=1)])
    episode = df.load(source, 0)
    return df.write(root / "clean", [episode]), episode


def test_the_clean_episode_raises_nothing(clean: tuple[Path, df.Clean]) -> None:
    root, episode = clean
    assert episode.n == N and set(episode.images) == {"cam"}
    assert df.findings(root) == {}


@pytest.mark.parametrize("kind", DETECTED)
def test_an_injected_fault_is_found_at_its_frames(kind: str, clean: tuple[Path, df.Clean], tmp_path: Path) -> None:
    _, episode = clean
    faulty, truth = df.inject(episode, kind, seed=3)
    got = df.findings(df.write(tmp_path / kind, [faulty])).get(0, [])
    at_frames, raised = df.found(df.labelled(truth, faulty), got, tol=2)
    assert raised, f"{kind}: no {df.EXPECTED[kind]} finding; got {got}"
    assert at_frames, f"{kind}: truth frames {truth.first}..{truth.last} {truth.dims or truth.camera}; got {got}"


def test_shuffled_tasks_move_every_task_to_another_episode(clean: tuple[Path, df.Clean], tmp_path: Path) -> None:
    """The trainability benchmark's defect (#51): each episode written with another episode's task text."""
    _, episode = clean
    texts = ["pick the cube", "open the drawer", "push the block"]
    episodes = [replace(episode, task=t) for t in texts]
    moved, truths = df.shuffle_tasks(episodes, seed=5)
    root = df.write(tmp_path / "shuffled", moved)
    read = [df.load(root, e).task for e in range(3)]
    assert sorted(read) == sorted(texts) and all(r != t for r, t in zip(read, texts, strict=True))
    assert [t.kind for t in truths] == ["shuffled_tasks"] * 3


def test_an_angle_written_in_degrees_is_found(clean: tuple[Path, df.Clean], tmp_path: Path) -> None:
    """The state's joints named as angles: clean they raise nothing; one of them in degrees is `degrees` over
    the whole episode (beyond 2π + 0.5: no angle in radians is), and no other dimension is."""
    _, episode = clean
    named = replace(episode, state_names=("joint_0", "joint_1", "joint_2"))
    assert df.findings(df.write(tmp_path / "radians", [named])) == {}
    faulty, truth = df.inject(named, "degrees_as_radians", seed=3)
    got = df.findings(df.write(tmp_path / "degrees", [faulty])).get(0, [])
    degrees = [f["subject"] for f in got if f["check"] == "degrees"]
    assert degrees == [f"observation.state[joint_{truth.dims[0]}]"]
    assert df.found(df.labelled(truth, faulty), got, tol=2) == (True, True)


def test_swapped_and_shifted_actions_are_found(clean: tuple[Path, df.Clean], tmp_path: Path) -> None:
    """Action dimensions named as the state's: clean, each drives its own state dimension at once; two swapped
    are `action_swap`, actions 5 frames early are `action_lag` (a scripted expert's limit: 4 frames)."""
    _, episode = clean
    named = replace(
        episode, state_names=("joint_0", "joint_1", "joint_2"), action_names=("joint_0", "joint_1", "gripper")
    )
    th = for_kind(DEFAULT, "scripted")
    assert df.findings(df.write(tmp_path / "clean", [named]), th) == {}
    for kind in ("swapped_actions", "action_shift"):
        faulty, truth = df.inject(named, kind, seed=3)
        got = df.findings(df.write(tmp_path / kind, [faulty]), th).get(0, [])
        assert df.found(df.labelled(truth, faulty), got, tol=2) == (True, True), (kind, got)
        assert {f["check"] for f in got} == {"action_swap" if kind == "swapped_actions" else "action_lag"}, got


def test_an_upside_down_camera_is_found_against_the_other_episodes(
    clean: tuple[Path, df.Clean], tmp_path: Path
) -> None:
    """Four episodes filming one scene (bright above, dark below, noise on top): the one whose camera is turned
    180° is `camera_flipped` over the whole episode, the others raise nothing (no reference picture needed)."""
    _, episode = clean
    rng = np.random.default_rng(0)
    scene = np.repeat(np.linspace(220, 40, episode.images["cam"].shape[1])[:, None], episode.images["cam"].shape[2], 1)
    episodes = []
    for e in range(4):  # each its own state (else `duplicate_episode`)
        noise = rng.integers(-30, 30, episode.images["cam"].shape)
        images = {"cam": np.clip(scene[None, :, :, None] + noise, 0, 255).astype(np.uint8)}
        episodes.append(replace(episode, state=episode.state + np.float32(0.01 * e), images=images))
    episodes[2], truth = df.inject(episodes[2], "upside_down", seed=3)
    got = df.findings(df.write(tmp_path / "flipped", episodes))
    assert sorted(got) == [2] and [f["check"] for f in got[2]] == ["camera_flipped"]
    assert df.found(df.labelled(truth, episodes[2]), got[2], tol=2) == (True, True)


def test_frozen_and_blurred_camera_spans_are_placed_to_the_frame_at_stride_5(
    clean: tuple[Path, df.Clean], tmp_path: Path
) -> None:
    """At the default stride (every 5th frame measured) a frozen or blurred span's edges fall between samples:
    the runs that raise a flag are decoded again at the full rate around their edges, so each span is reported
    to the frame (a frozen span from the first frame repeating the held one), not within half a stride."""
    _, episode = clean
    for kind, check, seed in (("frozen_camera", "camera_frozen", 3), ("blur", "camera_blurred", 5)):
        faulty, truth = df.inject(episode, kind, seed=seed)
        assert truth.first % 5 not in (0, 4) or truth.last % 5 not in (0, 1), "an edge mid-way between samples"
        got = df.findings(df.write(tmp_path / kind, [faulty]), stride=5).get(0, [])
        spans = [(f["start_frame"], f["end_frame"]) for f in got if f["check"] == check]
        assert len(spans) == 1, (kind, got)
        (start, end) = spans[0]
        # the first copy of a held picture may be coded as the live one before it: one frame either way
        assert abs(start - truth.first) <= (kind == "frozen_camera") and end == truth.last, (kind, truth, spans)


def test_joint_limits_and_velocities_from_the_robot_manifest(clean: tuple[Path, df.Clean], tmp_path: Path) -> None:
    """The state named as the SO-101's joints (robots/so101_follower: degrees, limits ±100..110, 180°/s): clean
    it raises nothing; elbow_flex written 150° over frames 20..24 is `joint_limit` over those frames (25 % of its
    range beyond) and `joint_velocity` where it leaves and comes back (1 500°/s at 10 fps); an unknown robot type
    is not checked."""
    _, episode = clean
    named = replace(episode, state_names=("shoulder_pan", "shoulder_lift", "elbow_flex"), robot_type="so101_follower")
    assert df.findings(df.write(tmp_path / "clean", [named])) == {}
    faulty = named.copy()
    faulty.state[20:25, 2] = 150.0
    got = df.findings(df.write(tmp_path / "beyond", [faulty])).get(0, [])
    spans = {(f["check"], f["subject"], f["start_frame"], f["end_frame"]) for f in got}
    elbow = f"{STATE}[elbow_flex]"
    expected = {("joint_limit", elbow, 20, 24), ("joint_velocity", elbow, 20, 20), ("joint_velocity", elbow, 25, 25)}
    assert expected <= spans
    (limit,) = [f for f in got if f["check"] == "joint_limit"]
    assert limit["value"] == pytest.approx(0.25, abs=0.01) and limit["threshold"] == DEFAULT.limit_margin
    other = replace(faulty, robot_type="some_other_arm")
    assert not {f["check"] for f in df.findings(df.write(tmp_path / "other", [other])).get(0, [])} & {
        "joint_limit",
        "joint_velocity",
    }


def test_a_still_scene_is_no_frozen_camera_but_a_held_picture_is(clean: tuple[Path, df.Clean], tmp_path: Path) -> None:
    """A camera whose picture stands still because nothing in its view moves (a block driven out of the
    picture, slowing at the edge, and back: a person's arm leaving an overhead camera's view) is neither
    `camera_frozen` nor `camera_stalled`, while the robot and the other camera move; the same camera's picture
    held for 14 frames while the block moves in view is, at its frames. Before: the still scene was both."""
    _, episode = clean
    n, side, block = 80, 48, 12
    x = np.r_[
        np.arange(18, 2, -4),
        np.arange(2, 30, 4),
        np.arange(30, 10, -4),  # in view, 4 px a frame
        np.arange(10, 0, -4),
        np.arange(0, -8, -2),
        [-9, -10, -11, -12],  # out of the left edge, slowing
        np.full(16, -12),
        [-11, -10, -9, -8],
        np.arange(-6, 2, 2),  # out of view, then back slowly
        np.arange(2, 30, 4),
        np.arange(30, 2, -4),
        np.arange(2, 30, 4),
        np.arange(30, 0, -4),
    ]
    assert len(x) == n
    background = np.random.default_rng(7).integers(40, 120, (side, side, 3), dtype=np.uint8)
    scene = np.repeat(background[None], n, axis=0)
    for k, left in enumerate(x):
        scene[k, 18 : 18 + block, max(0, left) : max(0, left + block)] = 250
    other = np.random.default_rng(8).integers(40, 216, (n, side, side, 3), dtype=np.uint8)
    t = np.arange(n)[:, None] / episode.fps
    wave = np.sin(2 * np.pi * t / 4.0 + np.array([0.0, 2.1, 4.2])).astype(np.float32)
    still = replace(
        episode, state=wave, action=wave * 0.8, time=t[:, 0].astype(np.float64), images={"scene": scene, "other": other}
    )
    cameras = ("camera_frozen", "camera_stalled")
    got = df.findings(df.write(tmp_path / "still", [still]), stride=5).get(0, [])
    assert not [f for f in got if f["check"] in cameras], got
    held = still.copy()
    held.images["scene"][58:72] = held.images["scene"][57]  # the block mid-way across the view, 14 frames
    got = df.findings(df.write(tmp_path / "held", [held]), stride=5).get(0, [])
    spans = {(f["check"], f["subject"], f["start_frame"], f["end_frame"]) for f in got if f["check"] in cameras}
    assert spans and all(s[1] == "observation.images.scene" for s in spans), spans
    assert all(abs(a - 58) <= 1 and b == 71 for _, _, a, b in spans), spans


def test_an_encoder_creeping_under_one_count_is_not_a_frozen_reading(
    clean: tuple[Path, df.Clean], tmp_path: Path
) -> None:
    """A joint read by an encoder in counts of 0.02 that slows to under a count per frame holds its reading 14
    frames while the other joints move, then steps by one count: a slow joint, not `frozen` (before: frozen). The
    same reading held 14 frames while the joint keeps its speed, then jumping to where it went: `frozen`, there."""
    _, episode = clean
    count = 0.02
    creep = np.r_[[0.0], [0.05] * 19, [0.03, 0.015, 0.005], [0.0008] * 12, [0.005, 0.015, 0.03], [0.05] * 22]
    slow = episode.copy()
    slow.state[:, 0] = np.round((np.cumsum(creep) + 0.013) / count) * count
    got = df.findings(df.write(tmp_path / "slow", [slow])).get(0, [])
    assert not [f for f in got if f["check"] == "frozen"], got
    stale = episode.copy()
    stale.state[:, 0] = np.round((np.arange(N) * 0.05 + 0.013) / count) * count
    stale.state[20:34, 0] = stale.state[19, 0]
    got = df.findings(df.write(tmp_path / "stale", [stale])).get(0, [])
    spans = [(f["subject"], f["start_frame"], f["end_frame"]) for f in got if f["check"] == "frozen"]
    assert spans == [(f"{STATE}[{episode.state_names[0]}]", 19, 33)], got


def test_a_camera_out_of_step_with_the_state_and_the_others_is_found(
    clean: tuple[Path, df.Clean], tmp_path: Path
) -> None:
    """Two cameras filming the arm (a pattern that moves with the state), the arm still for its first 6 frames:
    written in step, nothing; the wrist camera's frames paired 4 rows late, `camera_lag` on the wrist camera over
    the whole episode, 4 frames behind, and nothing on the front camera."""
    _, episode = clean
    state = episode.state.copy()
    state[:6] = state[6]
    yy, xx = np.mgrid[0:32, 0:32].astype(np.float32)

    def film(s: np.ndarray, fx: float) -> np.ndarray:
        luma = 128 + 60 * np.sin(fx * xx[None] + 3 * s[:, :1, None]) + 40 * np.cos(0.3 * yy[None] + 3 * s[:, 1:2, None])
        return np.repeat(np.clip(luma, 0, 255).astype(np.uint8)[..., None], 3, axis=3)

    images = {"front": film(state, 0.4), "wrist": film(state, 0.7)}
    in_step = replace(episode, state=state, images=images)
    lagged = replace(in_step, images={**images, "wrist": images["wrist"][np.maximum(np.arange(N) - 4, 0)]})
    got = df.findings(df.write(tmp_path / "lag", [in_step, lagged]), stride=5)
    lags = {e: [f for f in fs if f["check"] == "camera_lag"] for e, fs in got.items()}
    assert not lags.get(0), got.get(0)
    [found] = lags[1]
    assert found["subject"] == "observation.images.wrist" and found["value"] == 4.0, found
    assert (found["start_frame"], found["end_frame"]) == (0, N - 1), found


def test_frames_lost_where_the_arm_slows_down_are_found(clean: tuple[Path, df.Clean], tmp_path: Path) -> None:
    """Three joints moving together, 0.04 a frame, then 0.018 (a script slowing down for a grasp), the frames of
    the slowing lost (one step of 0.2 between them, timestamps even): `frame_drop` at the frame after the cut,
    though the steps either side disagree by more than 2x. The same motion slowing down, no frame lost, and a
    script speeding up (0.01 a frame, then 0.05 from one frame on) raise nothing."""
    _, episode = clean
    along = np.array([1.0, 0.5, 0.25])

    def moved(speeds: np.ndarray) -> df.Clean:
        ep = episode.copy()
        ep.state[:, :3] = (np.cumsum(speeds)[:, None] * along).astype(np.float32)
        ep.action[:, :3] = ep.state[:, :3]
        return ep

    lost = moved(np.r_[[0.04] * 25, [0.2], [0.018] * (N - 26)])
    slowed = moved(np.r_[[0.04] * 25, np.linspace(0.04, 0.018, 6), [0.018] * (N - 31)])
    faster = moved(np.r_[[0.01] * 25, [0.05] * (N - 25)])
    got = df.findings(df.write(tmp_path / "drop", [lost, slowed, faster]))
    drops = {e: [(f["start_frame"], f["end_frame"]) for f in fs if f["check"] == "frame_drop"] for e, fs in got.items()}
    assert drops.get(0) == [(25, 25)], got.get(0)
    assert not drops.get(1) and not drops.get(2), got


def test_frames_lost_that_the_camera_shows_are_found(clean: tuple[Path, df.Clean], tmp_path: Path) -> None:
    """Three joints moving steadily (0.02 a frame) and a camera filming a grating that slides with them (0.5 px a
    frame). 3 frames lost before frame 30 (timestamps even): the state steps 4x its neighbours (under
    `drop_factor`), the picture jumps 4x its neighbours' change: `frame_drop` at frame 30 about the camera. The
    same motion without the cut, a script speeding up 4x from frame 30 on (state and picture step up and stay)
    and a pause of 5 frames raise nothing."""
    _, episode = clean
    along = np.array([1.0, 0.5, 0.25])

    def filmed(speeds: np.ndarray, keep: np.ndarray | None = None) -> df.Clean:
        at = np.cumsum(speeds)
        x = np.arange(q.SIDE)
        grating = 128 + 100 * np.sin(2 * np.pi * (x[None, :] + 25 * at[:, None]) / 16)
        pictures = np.repeat(np.repeat(grating[:, None, :, None], q.SIDE, axis=1), 3, axis=3).astype(np.uint8)
        keep = np.arange(N) if keep is None else keep
        ep = replace(episode.copy(), images={"cam": pictures[keep]})
        ep.state[:, :3] = (at[keep, None] * along).astype(np.float32)
        ep.action[:, :3] = ep.state[:, :3]
        return ep

    lost = filmed(np.full(N + 3, 0.02), np.r_[np.arange(30), np.arange(33, N + 3)])
    steady = filmed(np.full(N, 0.02))
    faster = filmed(np.r_[[0.01] * 30, [0.04] * (N - 30)])
    paused = filmed(np.r_[[0.02] * 30, [0.0] * 5, [0.02] * (N - 35)])
    got = df.findings(df.write(tmp_path / "filmed", [lost, steady, faster, paused]), stride=5)
    drops = {e: [(f["subject"], f["start_frame"]) for f in fs if f["check"] == "frame_drop"] for e, fs in got.items()}
    assert drops.get(0) == [("observation.images.cam", 30)], got.get(0)
    assert not any(drops.get(e) for e in (1, 2, 3)), got
    assert not [f for f in got.get(0, []) if f["check"] == "teleport"], got[0]


def test_two_swapped_joint_targets_moving_alike_are_found(clean: tuple[Path, df.Clean], tmp_path: Path) -> None:
    """A joint sweep: three joints commanded along one curve at their own angles (0.2, 1.4, -0.9 rad), each
    state following its target a frame later. Swapping two targets changes no correlation, but each then lies
    near the other joint's angle: `action_swap` on both over the whole episode; the clean sweep raises none."""
    _, episode = clean
    wave = 0.3 * np.sin(np.arange(N) / 6.0)[:, None]
    target = (wave + np.array([0.2, 1.4, -0.9])).astype(np.float32)
    names = ("joint_0", "joint_1", "joint_2")
    sweep = replace(episode, state_names=names, action_names=names, action=target, state=np.r_[target[:1], target[:-1]])
    swapped = sweep.copy()
    swapped.action[:, [0, 1]] = swapped.action[:, [1, 0]]
    got = df.findings(df.write(tmp_path / "sweep", [sweep, swapped]), for_kind(DEFAULT, "scripted"))
    swaps = {
        e: [(f["subject"], f["start_frame"], f["end_frame"]) for f in fs if f["check"] == "action_swap"]
        for e, fs in got.items()
    }
    assert not swaps.get(0), got.get(0)
    assert swaps[1] == [("action[joint_0]", 0, N - 1), ("action[joint_1]", 0, N - 1)], got[1]


def test_a_small_teleport_and_one_among_a_jumpy_hands_jumps_are_found() -> None:
    """A joint creeping 0.002 of its range a frame jumps 0.07 of its range at frame 30 (a gamepad session's eef
    teleported by half its episode's range; 35x its local speed): `teleport` there. With three finger dimensions
    each snapping open and shut by 0.5 (about 16x their trembling speed: larger steps, less beyond), the joint's
    jump, the one most beyond its local speed, is still among the 5 kept."""
    n = 60
    z = np.zeros((n, 4))
    z[:, 0] = np.arange(n) * 0.002
    z[30:, 0] += 0.07
    got = rows.teleports(z[:, :1], ["j0"], STATE, DEFAULT, set())
    assert [(f.subject, f.start_frame) for f in got] == [(f"{STATE}[j0]", 30)], got
    tremble = np.where(np.arange(n) % 2 == 0, 0.06, -0.06)
    for d, at in ((1, 10), (2, 15), (3, 20)):
        z[:, d] = np.cumsum(tremble) * 0.5 + 0.5 * ((np.arange(n) >= at).astype(float) - (np.arange(n) >= at + 25))
    got = rows.teleports(z, ["j0", "finger_1", "finger_2", "finger_3"], STATE, DEFAULT, set())
    assert (f"{STATE}[j0]", 30) in [(f.subject, f.start_frame) for f in got], got


def test_a_persons_velocity_commands_shifted_5_frames_are_late_but_a_followers_position_targets_are_not(
    clean: tuple[Path, df.Clean], tmp_path: Path
) -> None:
    """People's data: a gamepad's velocity commands drive the state at once (the controller integrates them), so
    the same commands 5 frames early are `action_lag` (limit 4: `velocity_lag_frames`); position targets a real
    follower trails by up to 6 frames (`action_lag_frames`) are not, shifted the same."""
    _, episode = clean
    raw = np.random.default_rng(0).normal(size=(N + 2, 3))
    speed = (0.02 * (raw[:-2] + raw[1:-1] + raw[2:]) / 3).astype(np.float32)  # a hand's stick, smoothed
    state = np.cumsum(speed, axis=0) - speed  # the state steps by the command of the frame before
    joints = ("joint_0", "joint_1", "joint_2")
    vel = replace(episode, state_names=joints, action_names=("joint_0_vel", "joint_1_vel", "joint_2_vel"))
    vel = replace(vel, state=state, action=speed)
    pos = replace(vel, action_names=joints, action=np.r_[state[1:], state[-1:]])
    early = np.minimum(np.arange(N) + 5, N - 1)
    th = for_kind(DEFAULT, "person")
    lags = {}
    for name, ep in (("vel", vel), ("pos", pos)):
        got = df.findings(df.write(tmp_path / name, [ep, replace(ep, action=ep.action[early])]), th)
        lags[name] = {
            e: [(f["value"], f["threshold"]) for f in fs if f["check"] == "action_lag"] for e, fs in got.items()
        }
    assert {e: v for e, v in lags["vel"].items() if v} == {1: [(5.0, 4.0)]}, lags
    assert not any(lags["pos"].values()), lags


def test_a_dimension_moving_by_rounding_residue_is_no_jerk(clean: tuple[Path, df.Clean], tmp_path: Path) -> None:
    """An action dimension commanded as 0 but written as ±2e-31 (a generated episode's rotation delta: rounding
    of its quaternion arithmetic) holds still: nothing (before: `jerky` on it, its range of 4e-31 stretched to 1).
    The same dimension flickering by ±0.02 is `jerky` there."""
    _, episode = clean
    flicker = (-1.0) ** np.arange(N)
    residue = episode.copy()
    residue.action[:, 1] = flicker * 2e-31
    assert df.findings(df.write(tmp_path / "residue", [residue])) == {}
    shaky = episode.copy()
    shaky.action[:, 1] = flicker * 0.02
    got = df.findings(df.write(tmp_path / "shaky", [shaky])).get(0, [])
    assert {f["subject"] for f in got if f["check"] == "jerky"} == {f"action[{episode.action_names[1]}]"}, got


def test_a_gripper_closing_in_three_frames_or_a_one_count_flicker_is_no_teleport(
    clean: tuple[Path, df.Clean], tmp_path: Path
) -> None:
    """A state dimension closing in 3 frames (0.18, 0.26, 0.17 a frame, the Apple/Reachy fixture's gripper) or
    one of a single count's range flickering by that count: no `teleport` (before: both). One step alone of the
    same size (a reading jumping and staying) is a teleport, at its frame."""
    _, episode = clean
    closing = episode.copy()
    closing.state[:, 2] = np.r_[[0.0] * 30, np.cumsum([0.18, 0.26, 0.17]), [0.61] * (N - 33)]
    flicker = episode.copy()
    flicker.state[:, 2] = np.where(np.isin(np.arange(N), [20, 21, 44]), 0.0015, 0.0)
    for name, ep in (("closing", closing), ("flicker", flicker)):
        got = df.findings(df.write(tmp_path / name, [ep])).get(0, [])
        assert not [f for f in got if f["check"] == "teleport"], (name, got)
    jump = episode.copy()
    jump.state[:, 2] = np.r_[[0.0] * 31, [0.26] * (N - 31)] + np.arange(N) * 0.002
    got = df.findings(df.write(tmp_path / "jump", [jump])).get(0, [])
    assert [(f["subject"], f["start_frame"]) for f in got if f["check"] == "teleport"] == [
        (f"{STATE}[{episode.state_names[2]}]", 31)
    ], got
