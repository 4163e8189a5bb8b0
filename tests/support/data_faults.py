"""Data fault injection: one known fault put into a clean LeRobot v3 episode, written as a new dataset through
our writer, with the truth (kind, subject, frames) a quality check should report (docs/stats.md, "Quality").

`load(root, episode)` reads an episode (ours or a foreign one: numbers with pyarrow, pictures decoded with PyAV
by our reader), `inject(clean, kind, seed)` returns the faulty copy and its `Truth`, `write(root, episodes)`
writes episodes through `LeRobotV3Writer` (straight to the sink: the recording bridge refuses NaN, which is one
of the faults). `shuffle_tasks` permutes the task of each episode among episodes (a dataset-level fault).
Kept apart from `faults.py` (a failing disk).

Frames in `Truth` are the first and last frame (inclusive) of the written episode where the fault shows: a
point fault (a teleport, a NaN, an angle wrap) has first == last, a fault of the whole episode (swapped action
dimensions, degrees, a shifted action, an upside-down camera) spans it all.
"""

from __future__ import annotations

import json
import re
from collections import defaultdict
from collections.abc import Iterable
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
import pyarrow as pa
import pyarrow.compute as pc
import pyarrow.parquet as pq

from openral_data.formats.lerobot_v3 import LeRobotV3Writer
from openral_data.formats.lerobot_v3.features import camera_keys, dim_names
from openral_data.formats.lerobot_v3.frames import episode_frames
from openral_data.formats.lerobot_v3.reader import dataset_tasks, read_episodes
from openral_data.metrics.quality import DEFAULT, Thresholds, limits, quality
from openral_data.types import CameraShape, DatasetSchema, EpisodeStart, Frame

F32 = npt.NDArray[np.float32]
U8 = npt.NDArray[np.uint8]

KINDS = (
    "idle_head",
    "idle_tail",
    "frozen_camera",
    "black_camera",
    "blur",
    "dropped_frames",
    "duplicated_frames",
    "timestamp_gap",
    "quaternion_flip",
    "angle_wrap",
    "swapped_actions",
    "degrees_as_radians",
    "action_shift",
    "gripper_chatter",
    "clipping",
    "nan",
    "teleport",
    "camera_lag",
    "upside_down",
)
# the check (a name of the quality findings) each fault kind should raise (docs/stats.md, "Quality")
EXPECTED: dict[str, tuple[str, ...]] = {
    "idle_head": ("idle",),
    "idle_tail": ("idle",),
    "frozen_camera": ("camera_frozen", "camera_stalled"),
    "black_camera": ("camera_black",),
    "blur": ("camera_blurred",),
    "dropped_frames": ("frame_drop",),
    "duplicated_frames": ("repeated_rows",),
    "timestamp_gap": ("gap",),
    "quaternion_flip": ("quat_flip",),
    "angle_wrap": ("angle_wrap",),
    "swapped_actions": ("action_swap",),
    "degrees_as_radians": ("degrees",),
    "action_shift": ("action_lag",),
    "gripper_chatter": ("chatter",),
    "clipping": ("clipped",),
    "nan": ("non_finite",),
    "teleport": ("teleport",),
    "camera_lag": ("camera_lag",),
    "upside_down": ("camera_flipped",),
}
CAMERA_KINDS = ("frozen_camera", "black_camera", "blur", "camera_lag", "upside_down")


class NotApplicable(ValueError):
    """The episode has nothing the fault could go into (no camera, no quaternion, one camera for a lag...)."""


@dataclass
class Clean:
    """One episode in memory: state/action (frames, dims), timestamps in seconds, each camera's frames."""

    fps: int
    state_names: tuple[str, ...]
    action_names: tuple[str, ...]
    state: F32
    action: F32
    time: npt.NDArray[np.float64]
    images: dict[str, U8] = field(default_factory=dict)  # camera -> (frames, H, W, 3)
    task: str = "task"
    robot_type: str | None = None

    @property
    def n(self) -> int:
        return len(self.state)

    def copy(self) -> Clean:
        return replace(
            self,
            state=self.state.copy(),
            action=self.action.copy(),
            time=self.time.copy(),
            images={k: v.copy() for k, v in self.images.items()},
        )

    def rows(self, index: npt.NDArray[np.int64]) -> Clean:
        """These frames (in this order) of every stream, timestamps re-spaced at 1/fps."""
        return replace(
            self,
            state=self.state[index],
            action=self.action[index],
            time=np.arange(len(index)) / self.fps,
            images={k: v[index] for k, v in self.images.items()},
        )


@dataclass(frozen=True)
class Truth:
    """Where the fault is: `feature` is observation.state, action, timestamp, task or a camera's name (`camera`
    set); `dims` the vector dimensions touched; `first`..`last` the frames (inclusive)."""

    kind: str
    feature: str
    first: int
    last: int
    dims: tuple[int, ...] = ()
    camera: str | None = None
    detail: str = ""


def labelled(t: Truth, clean: Clean) -> dict[str, object]:
    """A truth with its subjects named as the quality findings name them (`feature[name]`, a camera's key)."""
    names = clean.state_names if t.feature == "observation.state" else clean.action_names
    subjects = [f"{t.feature}[{names[d]}]" for d in t.dims]
    if t.camera is not None:
        subjects = [f"observation.images.{t.camera}"]
    return {**asdict(t), "subjects": subjects}


def load(root: Path, episode: int, *, max_side: int | None = None, max_frames: int | None = None) -> Clean:
    """Episode `episode` of LeRobot v3 dataset `root`; pictures subsampled (every k-th pixel) until their longer
    side is at most `max_side`, and only the first `max_frames` frames, when given (a small calibration corpus)."""
    info = json.loads((root / "meta" / "info.json").read_text())
    row = next(r for r in read_episodes(root).to_pylist() if int(r["episode_index"]) == episode)
    keys = camera_keys(info["features"])  # a video camera whose files are absent is left out
    cams = [
        c for c, key in keys.items() if info["features"][key]["dtype"] != "video" or (root / "videos" / key).is_dir()
    ]
    state, action, task = [], [], "task"
    images: dict[str, list[U8]] = {c: [] for c in cams}
    for i, frame in enumerate(episode_frames(root, info, row, dataset_tasks(root, info), cams)):
        if max_frames is not None and i >= max_frames:
            break
        state.append(frame.state)
        action.append(frame.action)
        task = frame.task or task
        for c in cams:
            img = frame.images[c]
            if img.ndim != 3 or img.shape[2] != 3:
                continue  # a depth map or a mask: not a picture
            k = 1 if max_side is None else -(-max(img.shape[:2]) // max_side)
            small = img[::k, ::k]
            images[c].append(np.ascontiguousarray(small[: small.shape[0] // 2 * 2, : small.shape[1] // 2 * 2]))
    feats = info["features"]
    return Clean(
        fps=int(info["fps"]),
        state_names=tuple(dim_names(feats["observation.state"], "observation.state")),
        action_names=tuple(dim_names(feats["action"], "action")),
        state=np.asarray(state, dtype=np.float32),
        action=np.asarray(action, dtype=np.float32),
        time=stored_times(root, episode, len(state)),
        images={c: np.asarray(v, dtype=np.uint8) for c, v in images.items() if len(v) == len(state)},
        task=task,
        robot_type=info.get("robot_type"),
    )


def schema(ep: Clean) -> DatasetSchema:
    cams = {c: CameraShape(int(v.shape[1]), int(v.shape[2])) for c, v in ep.images.items()}
    return DatasetSchema(
        fps=ep.fps, state_names=ep.state_names, action_names=ep.action_names, cameras=cams, robot_type=ep.robot_type
    )


def write(root: Path, episodes: list[Clean]) -> Path:
    """`episodes` (one schema) as a new LeRobot v3 dataset at `root`, through our writer."""
    writer = LeRobotV3Writer(root, schema(episodes[0]))
    for e, ep in enumerate(episodes):
        writer.begin_episode(EpisodeStart(seed=e, initial_state={}))
        for t in range(ep.n):
            writer.add_frame(
                Frame(
                    state=ep.state[t],
                    action=ep.action[t],
                    images={c: v[t] for c, v in ep.images.items()},
                    task=ep.task,
                    reward=0.0,
                    done=t == ep.n - 1,
                    success=t == ep.n - 1,
                    timestamp=float(ep.time[t]),
                )
            )
        writer.end_episode(True)
    writer.close()
    restamp(root, episodes)
    return root


def restamp(root: Path, episodes: list[Clean]) -> None:
    """Our writer stores frame_index / fps as each frame's timestamp: the episodes' own timestamps (a clock that
    jumps) are put into the data files afterwards, with pyarrow, where they differ."""
    stamps = {e: ep.time for e, ep in enumerate(episodes)}
    for path in sorted((root / "data").rglob("*.parquet")):
        table = pq.read_table(path)
        ep_col = table.column("episode_index").to_numpy()
        frame = table.column("frame_index").to_numpy()
        new = np.array([stamps[int(e)][int(f)] for e, f in zip(ep_col, frame, strict=True)], dtype=np.float32)
        if np.array_equal(new, table.column("timestamp").to_numpy()):
            continue
        i = table.schema.get_field_index("timestamp")
        table = table.set_column(i, table.schema.field(i), pa.array(new, type=pa.float32()))
        pq.write_table(table, path)


def stored_times(root: Path, episode: int, n: int) -> npt.NDArray[np.float64]:
    """Episode `episode`'s first `n` timestamps as stored (in frame order), from its data files."""
    parts = []
    for path in sorted((root / "data").rglob("*.parquet")):
        table = pq.read_table(path, columns=["episode_index", "frame_index", "timestamp"])
        table = table.filter(pc.equal(table.column("episode_index"), episode))
        if table.num_rows:
            parts.append(table)
    table = pa.concat_tables(parts).sort_by("frame_index")
    t = table.column("timestamp").to_numpy().astype(np.float64)[:n]
    return t - t[0]


def shuffle_tasks(episodes: list[Clean], seed: int = 0) -> tuple[list[Clean], list[Truth]]:
    """Each episode's task text moved to another episode (a derangement: no episode keeps its own, unless all
    tasks are one text); the truth of each moved episode."""
    tasks = [ep.task for ep in episodes]
    if len(set(tasks)) < 2:
        raise NotApplicable("every episode has the same task")
    n = len(episodes)
    p = np.random.default_rng(seed).permutation(n)
    source = np.empty(n, dtype=np.int64)
    source[p] = np.roll(p, -1)  # episode p[i] takes p[i+1]'s task: one cycle, no episode keeps its own
    out, truths = [], []
    for e, ep in enumerate(episodes):
        moved = replace(ep, task=tasks[int(source[e])])
        out.append(moved)
        if moved.task != ep.task:
            truths.append(
                Truth("shuffled_tasks", "task", 0, ep.n - 1, detail=f"episode {e}: {ep.task!r} -> {moved.task!r}")
            )
    return out, truths


QUATERNION = re.compile(r"(?:^|[_.])(?:q|quat|quaternion|rot|orientation)[_.]?([wxyz])$", re.IGNORECASE)
ANGLE = re.compile(r"roll|pitch|yaw|angle|theta|joint|shoulder|elbow|wrist|waist|^j\d|^q\d", re.IGNORECASE)
GRIPPER = re.compile(r"grip|finger|claw|hand", re.IGNORECASE)


def moving_dims(x: F32) -> list[int]:
    """Dimensions whose value changes in the episode (NaN-free)."""
    return [int(d) for d in np.flatnonzero(np.nanmax(x, axis=0) - np.nanmin(x, axis=0) > 1e-6)] if len(x) else []


def quaternion_dims(names: tuple[str, ...]) -> tuple[int, ...] | None:
    """Four consecutive dimensions named as a quaternion's w, x, y, z (in any order), if any."""
    for a in range(len(names) - 3):
        parts = [QUATERNION.search(names[a + k]) for k in range(4)]
        if all(parts) and {m.group(1).lower() for m in parts if m} == set("wxyz"):
            return tuple(range(a, a + 4))
    return None


def gripper_dim(ep: Clean) -> int:
    named = [d for d, name in enumerate(ep.action_names) if GRIPPER.search(name)]
    moving = moving_dims(ep.action)
    for d in named:
        if d in moving:
            return d
    raise NotApplicable("no moving action dimension named as a gripper")


def arm_dims(ep: Clean, x: F32, names: tuple[str, ...]) -> list[int]:
    """Moving dimensions that are not the gripper, the quaternion or NaN."""
    quat = quaternion_dims(names) or ()
    out = [d for d in moving_dims(x) if d not in quat and not GRIPPER.search(names[d])]
    if not out:
        raise NotApplicable("no moving arm dimension")
    return out


def span(n: int, rng: np.random.Generator, length: int) -> tuple[int, int]:
    """A span of `length` frames (first, end exclusive) away from the episode's first and last fifth."""
    length = min(length, max(1, n // 3))
    lo, hi = n // 5, max(n // 5 + 1, n - n // 5 - length)
    s = int(rng.integers(lo, hi))
    return s, s + length


def camera(ep: Clean, rng: np.random.Generator) -> str:
    if not ep.images:
        raise NotApplicable("no camera")
    return sorted(ep.images)[int(rng.integers(len(ep.images)))]


def box_blur(img: U8, radius: int) -> U8:
    """A separable box blur of `radius` pixels (edges clamped), twice: close to a Gaussian."""
    x = img.astype(np.float32)
    for _ in range(2):
        for axis in (0, 1):
            pad = [(0, 0)] * x.ndim
            pad[axis] = (radius, radius)
            c = np.cumsum(np.pad(x, pad, mode="edge"), axis=axis, dtype=np.float64)
            c = np.concatenate([np.zeros_like(c.take([0], axis=axis)), c], axis=axis)
            k = 2 * radius + 1
            x = ((c.take(range(k, c.shape[axis]), axis=axis) - c.take(range(c.shape[axis] - k), axis=axis)) / k).astype(
                np.float32
            )
    return np.clip(np.rint(x), 0, 255).astype(np.uint8)


def pad_idle(ep: Clean, m: int, head: bool) -> tuple[Clean, Truth]:
    n = ep.n
    index = np.r_[np.zeros(m, dtype=np.int64), np.arange(n)] if head else np.r_[np.arange(n), np.full(m, n - 1)]
    out = ep.rows(index)
    first = 0 if head else n
    return out, Truth("idle_head" if head else "idle_tail", "observation.state", first, first + m - 1)


HOLD_VISIBLE = 1.0  # mean absolute difference (0-255) a held picture must make to the frames it replaces
HOLD_TRIES = 8


def held_span(v: U8, n: int, rng: np.random.Generator) -> tuple[int, int]:
    """A span for a frozen camera whose held picture changes the data: over the span, the held frame differs from
    the clean frames it replaces by `HOLD_VISIBLE` on average. A hold put where the picture already stands still
    (a person's arm out of an overhead camera's view) leaves the episode as it was: no fault anyone could find.
    The first draw is kept when it qualifies (the same span as before this rule)."""
    for _ in range(HOLD_TRIES):
        s, e = span(n, rng, max(10, n // 5))
        change = np.abs(v[s + 1 : e].astype(np.int16) - v[s].astype(np.int16)).mean() if e > s + 1 else 0.0
        if change >= HOLD_VISIBLE:
            return s, e
    raise NotApplicable(f"the picture stands still in every span tried ({HOLD_TRIES}): a hold would change nothing")


def camera_fault(ep: Clean, kind: str, rng: np.random.Generator) -> tuple[Clean, Truth]:
    cam, n = camera(ep, rng), ep.n
    v = ep.images[cam]
    if kind == "frozen_camera":
        s, e = held_span(v, n, rng)
        v[s:e] = v[s]
        return ep, Truth(kind, cam, s + 1, e - 1, camera=cam)
    s, e = span(n, rng, max(10, n // 5))
    if kind == "black_camera":
        v[s:e] = 0
        return ep, Truth(kind, cam, s, e - 1, camera=cam)
    if kind == "blur":
        radius = max(2, max(v.shape[1:3]) // 16)
        for t in range(s, e):
            v[t] = box_blur(v[t], radius)
        return ep, Truth(kind, cam, s, e - 1, camera=cam, detail=f"box blur radius {radius} px, twice")
    if kind == "camera_lag":
        lag = 3
        v[:] = v[np.maximum(np.arange(n) - lag, 0)]
        return ep, Truth(kind, cam, 0, n - 1, camera=cam, detail=f"{lag} frames behind the state and the others")
    v[:] = v[:, ::-1, ::-1]  # upside_down: turned 180 degrees
    return ep, Truth(kind, cam, 0, n - 1, camera=cam)


def timing_fault(ep: Clean, kind: str, rng: np.random.Generator) -> tuple[Clean, Truth]:
    n = ep.n
    k = int(rng.integers(n // 4, 3 * n // 4))
    if kind == "dropped_frames":
        d = max(5, n // 20)
        out = ep.rows(np.r_[np.arange(k), np.arange(k + d, n)])  # timestamps even: the loss is hidden
        return out, Truth(kind, "observation.state", k, k, detail=f"{d} frames removed before frame {k}")
    if kind == "duplicated_frames":
        d = 3
        out = ep.rows(np.r_[np.arange(k + 1), np.full(d, k), np.arange(k + 1, n)])
        return out, Truth(kind, "observation.state", k + 1, k + d, detail=f"frame {k} written {d + 1} times")
    gap = 5  # timestamp_gap: the clock jumps, the data does not
    ep.time[k:] += gap / ep.fps
    return ep, Truth(kind, "timestamp", k, k, detail=f"{gap} periods missing before frame {k}")


def wrap_dim(ep: Clean, rng: np.random.Generator) -> int:
    """A moving state dimension that is an angle: a revolute joint of the robot's manifest (`limits.robot_joints`),
    else named as one (a joint, roll/pitch/yaw; a generic `j0` counts)."""
    revolute = limits.robot_joints(ep.robot_type, list(ep.state_names)).revolute()
    angles = [d for d in arm_dims(ep, ep.state, ep.state_names) if d in revolute or ANGLE.search(ep.state_names[d])]
    if not angles:
        raise NotApplicable("no moving state dimension that is an angle")
    return angles[int(rng.integers(len(angles)))]


def in_degrees(x: F32) -> bool:
    """Whether an angle's values go beyond ±(2π + 0.5): written in degrees (LeRobot's Feetech arms)."""
    return float(np.nanmax(np.abs(x))) > 2 * np.pi + 0.5


def angle_wrap(ep: Clean, rng: np.random.Generator) -> tuple[Clean, Truth]:
    """An angle written in (-pi, pi]: the dimension offset so that it crosses +-pi between two moving frames
    near the middle, then wrapped; the truth is the first frame it jumps by about 2 pi."""
    x, d = ep.state, wrap_dim(ep, rng)
    step = np.diff(x[:, d].astype(np.float64))
    middle = np.arange(ep.n // 4, 3 * ep.n // 4)
    moving = middle[np.abs(step[middle - 1]) > 0]
    if not len(moving):
        raise NotApplicable(f"observation.state[{d}] does not move in the middle of the episode")
    k = int(rng.choice(moving))
    half = 180.0 if in_degrees(x[:, d]) else np.pi  # an angle in degrees wraps at ±180
    edge = half if step[k - 1] > 0 else -half
    y = x[:, d].astype(np.float64) + edge - (x[k - 1, d] + x[k, d]) / 2.0
    x[:, d] = (np.mod(y + half, 2 * half) - half).astype(np.float32)
    first = int(np.flatnonzero(np.abs(np.diff(x[:, d])) > half)[0]) + 1
    return ep, Truth("angle_wrap", "observation.state", first, first, dims=(d,))


def state_fault(ep: Clean, kind: str, rng: np.random.Generator) -> tuple[Clean, Truth]:
    n, x = ep.n, ep.state
    k = int(rng.integers(n // 4, 3 * n // 4))
    if kind == "quaternion_flip":
        quat = quaternion_dims(ep.state_names)
        if quat is None:
            raise NotApplicable("no quaternion among the state's names")
        x[k:, list(quat)] *= -1  # the same rotation from frame k on, its sign flipped
        return ep, Truth(kind, "observation.state", k, k, dims=quat)
    if kind == "angle_wrap":
        return angle_wrap(ep, rng)
    if kind == "degrees_as_radians":
        d = wrap_dim(ep, rng)
        if in_degrees(x[:, d]):
            raise NotApplicable(f"observation.state[{d}] is in degrees already")
        x[:, d] = np.degrees(x[:, d])
        return ep, Truth(kind, "observation.state", 0, n - 1, dims=(d,))
    if kind == "teleport":
        d = arm_dims(ep, x, ep.state_names)[int(rng.integers(len(arm_dims(ep, x, ep.state_names))))]
        jump = 0.5 * float(np.ptp(x[:, d]))
        x[k:, d] += np.float32(jump if x[k, d] <= np.median(x[:, d]) else -jump)
        return ep, Truth(kind, "observation.state", k, k, dims=(d,), detail=f"half its range ({jump:.4g})")
    bad = np.float32(np.nan if rng.integers(2) == 0 else np.inf)  # nan
    feature, v, names = (
        ("observation.state", x, ep.state_names) if rng.integers(2) == 0 else ("action", ep.action, ep.action_names)
    )
    d = int(rng.integers(len(names)))
    v[k, d] = bad
    return ep, Truth("nan", feature, k, k, dims=(d,), detail=str(bad))


def clip_run(a: F32, d: int, sign: float) -> tuple[int, int, np.float32] | None:
    """The frames around dimension `d`'s highest point (`sign` -1: lowest) inside the episode's middle three fifths
    beyond a level 30 % of its range inside it (first, end), and that level; None when that excursion is not
    entered and left inside the episode (a limit clips a top: the motion comes back below it)."""
    n = len(a)
    y = sign * a[:, d].astype(np.float64)
    lo, hi = n // 5, n - n // 5
    top = lo + int(np.argmax(y[lo:hi]))
    level = y[top] - 0.3 * float(np.ptp(y))
    s, e = top, top + 1
    while s > 0 and y[s - 1] > level:
        s -= 1
    while e < n and y[e] > level:
        e += 1
    return (s, e, np.float32(sign * level)) if s > 0 and e < n else None


def action_fault(ep: Clean, kind: str, rng: np.random.Generator) -> tuple[Clean, Truth]:
    n, a = ep.n, ep.action
    if kind == "swapped_actions":
        dims = arm_dims(ep, a, ep.action_names)
        if len(dims) < 2:
            raise NotApplicable("fewer than two moving arm action dimensions")
        i, j = (int(v) for v in rng.choice(dims, 2, replace=False))
        a[:, [i, j]] = a[:, [j, i]]
        return ep, Truth(kind, "action", 0, n - 1, dims=(min(i, j), max(i, j)))
    if kind == "action_shift":
        k = 5
        a[:] = a[np.minimum(np.arange(n) + k, n - 1)]
        return ep, Truth(kind, "action", 0, n - 1, detail=f"actions {k} frames early against the state")
    if kind == "gripper_chatter":
        d = gripper_dim(ep)
        lo, hi = float(np.nanmin(a[:, d])), float(np.nanmax(a[:, d]))
        s, e = span(n, rng, 20)
        a[s:e, d] = np.where(np.arange(e - s) % 2 == 0, lo, hi)
        return ep, Truth(kind, "action", s, e - 1, dims=(d,))
    raise ValueError(kind)


def clipping(ep: Clean, rng: np.random.Generator) -> tuple[Clean, Truth]:
    """A state dimension held flat around its peak or its trough (a joint stopped by a limit, a sensor at full
    scale), entered and left inside the episode: the first dimension (in a random order) that has one."""
    x = ep.state
    dims = arm_dims(ep, x, ep.state_names)
    for d in (int(v) for v in rng.permutation(dims)):
        for sign in (1.0, -1.0) if rng.integers(2) == 0 else (-1.0, 1.0):
            found = clip_run(x, d, sign)
            if found is not None and found[1] - found[0] >= 3:
                s, e, level = found
                x[s:e, d] = level
                detail = f"held at {float(level):.4g}"
                return ep, Truth("clipping", "observation.state", s, e - 1, dims=(d,), detail=detail)
    raise NotApplicable("no state dimension peaks for 3 frames inside the episode")


def inject(clean: Clean, kind: str, seed: int = 0) -> tuple[Clean, Truth]:
    """A copy of `clean` with one fault of `kind` (one of `KINDS`), placed by `seed`; `NotApplicable` when the
    episode has nothing the fault could go into."""
    rng = np.random.default_rng(seed)
    ep = clean.copy()
    if ep.n < 20:
        raise NotApplicable(f"{ep.n} frames: too short")
    if kind in ("idle_head", "idle_tail"):
        return pad_idle(ep, max(10, ep.n // 4), kind == "idle_head")
    if kind in CAMERA_KINDS:
        return camera_fault(ep, kind, rng)
    if kind in ("dropped_frames", "duplicated_frames", "timestamp_gap"):
        return timing_fault(ep, kind, rng)
    if kind in ("quaternion_flip", "angle_wrap", "degrees_as_radians", "teleport", "nan"):
        return state_fault(ep, kind, rng)
    if kind == "clipping":
        return clipping(ep, rng)
    if kind in ("swapped_actions", "action_shift", "gripper_chatter"):
        return action_fault(ep, kind, rng)
    raise ValueError(f"unknown fault kind {kind!r}; one of {', '.join(KINDS)}")


def findings(root: Path, th: Thresholds = DEFAULT, stride: int = 1) -> dict[int, list[dict[str, Any]]]:
    """Each episode's flagging findings (check, subject, start_frame, end_frame, value, threshold) under `th`,
    every `stride`-th camera frame measured."""
    q = quality(root, stride=stride, thresholds=th)
    out: dict[int, list[dict[str, Any]]] = defaultdict(list)
    for r in pq.read_table(q.paths.findings).to_pylist():
        if r["flag"]:
            out[int(r["episode_index"])].append(r)
    return dict(out)


def near(span: tuple[int, int], first: int, last: int, tol: int) -> bool:
    """`span` reaches the truth's frames within `tol` on both sides and starts or ends within `tol` of them."""
    a, b = span
    return a <= first + tol and b >= last - tol and (abs(a - first) <= tol or abs(b - last) <= tol)


def merged(spans: Iterable[tuple[int, int]], tol: int) -> list[tuple[int, int]]:
    """Spans closer than `tol` frames joined (a fault reported in pieces, e.g. blurred frames between flat ones)."""
    out: list[tuple[int, int]] = []
    for a, b in sorted(spans):
        if out and a <= out[-1][1] + tol + 1:
            out[-1] = (out[-1][0], max(out[-1][1], b))
        else:
            out.append((a, b))
    return out


WHOLE = ("episode", "timestamp")  # findings about no one dimension or camera: they match any subject


def first_subject(subject: str) -> str:
    """A grouped subject's first member (`observation.state[eef_qx..w]`: `observation.state[eef_qx]`)."""
    head, _, rest = subject.partition("[")
    return f"{head}[{rest.split('..')[0].rstrip(']')}]" if ".." in rest else subject


def found(truth: dict[str, Any], got: Iterable[dict[str, Any]], tol: int) -> tuple[bool, bool]:
    """(the expected check about the subject at the right frames, the expected check anywhere): `truth` as
    `labelled` makes it, `got` one episode's flagging findings."""
    checks = EXPECTED[truth["kind"]]
    mine = [f for f in got if f["check"] in checks or any(f["check"].startswith(c) for c in checks if c.endswith("_"))]
    subjects = set(truth["subjects"])
    about = [f for f in mine if not subjects or first_subject(f["subject"]) in subjects or f["subject"] in WHOLE]
    by_subject: dict[tuple[str, str], list[tuple[int, int]]] = defaultdict(list)
    for f in about:
        if f["start_frame"] is not None and f["end_frame"] is not None:
            by_subject[(f["check"], f["subject"])].append((int(f["start_frame"]), int(f["end_frame"])))
    at = any(near(s, truth["first"], truth["last"], tol) for v in by_subject.values() for s in merged(v, tol))
    return at, bool(mine)
