"""Signals that load fine and still mean the wrong thing, found in one episode's frames (numpy only, no I/O):

* `quaternion_flips`: a quaternion whose sign flips between two frames (q and -q are one orientation, so a
  writer forcing w >= 0 or a source switching hemispheres makes a square wave a policy learns as motion). A
  quaternion is a 4-value feature whose key says `quat`, or four columns named by a common prefix and the
  components x, y, z, w (`eef_qx` .. `eef_qw`, `quat_x` .., `orientation.x` ..). A flip is two consecutive
  unit-normalised quaternions whose dot product is below -`FLIP_DOT` (an actual rotation between two frames
  keeps it near +1); order of the components does not matter.
* `angle_wraps`: an angle-like column (its name says yaw/pitch/roll/angle/theta/heading/joint/rx/ry/rz...) that
  jumps by about 2π between two frames (within `WRAP_SLACK` rad; or 360 within as many degrees: an angle in
  degrees): the angle was wrapped into (-π, π] (or [0, 2π), (-180, 180]) instead of being kept continuous.
* `rate_mismatch`: timestamps whose step is not the declared fps: the frames where
  `|t_k - (t_0 + k / fps)|` exceeds half a frame period, and the median step.

Each returns `Signal`s naming the column(s) and the frames (positions in the episode); `doctor` turns them into
warnings and the quality checks can build on the same functions.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

FLIP_DOT = 0.5  # dot(q_t, q_t+1) < -0.5: a sign flip, not a rotation (that would be > 120° in one frame)
WRAP_SLACK = 0.5  # rad: a jump of 2π ± this is a wrap
MAX_FRAMES = 5  # frames listed per finding
ANGLE_NAME = re.compile(
    r"(yaw|pitch|roll|angle|theta|phi|psi|heading|euler|joint|(^|[._\-])r[xyz]$|(^|[._\-])rot[_.]?[xyz]$)",
    re.IGNORECASE,
)
QUAT_COMPONENT = re.compile(r"^(?P<prefix>.*?)(?P<marker>q|quat[_.]?|orientation[_.]?|ori[_.]?)(?P<c>[xyzw])$")
Array = npt.NDArray[np.float64]


@dataclass(frozen=True)
class Signal:
    columns: tuple[str, ...]  # the column(s) it is about, as `feature[name]` (or `feature` for a scalar)
    frames: tuple[int, ...]  # where (frame positions in the episode), at most `MAX_FRAMES`
    count: int  # how many such frames in all
    detail: str = ""


def dimension_names(key: str, feature: dict[str, object], width: int) -> list[str]:
    """One name per value of `key`'s frame vector: info.json's `names` (a list, a nested list, or a dict of
    lists as some writers store them) when it has `width` of them, else `key[i]`."""
    names: object = feature.get("names")
    if isinstance(names, dict):
        names = next((v for v in names.values() if isinstance(v, list)), None)
    if isinstance(names, list) and len(names) == 1 and isinstance(names[0], list):
        names = names[0]
    if isinstance(names, list) and len(names) == width and all(isinstance(n, str) for n in names):
        return [str(n) for n in names]
    return [f"{key}[{i}]" for i in range(width)]


def quaternion_groups(key: str, names: list[str]) -> list[tuple[str, list[int]]]:
    """(label, the 4 positions) of each quaternion in a feature whose dimensions are `names` (module docstring)."""
    if "quat" in key.lower() and len(names) == 4:
        return [(key, [0, 1, 2, 3])]
    groups: dict[str, dict[str, int]] = {}
    for i, name in enumerate(names):
        m = QUAT_COMPONENT.match(name.lower())
        if m:
            groups.setdefault(m["prefix"] + m["marker"], {})[m["c"]] = i
    return [(f"{key}[{p}x..w]", [g[c] for c in "xyzw"]) for p, g in groups.items() if len(g) == 4]


def quaternion_flips(values: Array, key: str, names: list[str]) -> list[Signal]:
    """Sign flips of each quaternion of `values` (frames x dims of feature `key`)."""
    out: list[Signal] = []
    for label, dims in quaternion_groups(key, names):
        q = np.asarray(values[:, dims], dtype=np.float64)
        norm = np.linalg.norm(q, axis=1, keepdims=True)
        q = np.divide(q, norm, out=np.zeros_like(q), where=norm > 0)
        dots = np.einsum("ij,ij->i", q[:-1], q[1:])
        frames = np.flatnonzero(dots < -FLIP_DOT) + 1
        if len(frames):
            out.append(
                Signal((label,), tuple(int(f) for f in frames[:MAX_FRAMES]), len(frames), "q -> -q (same orientation)")
            )
    return out


def angle_wraps(values: Array, key: str, names: list[str], also: frozenset[int] = frozenset()) -> list[Signal]:
    """Jumps of about 2π (or 360: an angle in degrees) between consecutive frames in the angle-like columns of
    `values` (frames x dims of feature `key`, whose dimensions are `names`), and in the columns `also` names (a
    robot manifest's revolute joints, whatever their names)."""
    out: list[Signal] = []
    for i, name in enumerate(names):
        if not ANGLE_NAME.search(name) and i not in also:
            continue
        step = np.abs(np.diff(np.asarray(values[:, i], dtype=np.float64)))
        wrap = (np.abs(step - 2 * math.pi) < WRAP_SLACK) | (np.abs(step - 360.0) < math.degrees(WRAP_SLACK))
        frames = np.flatnonzero(wrap) + 1
        if len(frames):
            where = tuple(int(f) for f in frames[:MAX_FRAMES])
            unit = "rad" if float(step[frames[0] - 1]) < 2 * math.pi + WRAP_SLACK else "deg"
            out.append(Signal((f"{key}[{name}]",), where, len(frames), f"jump {float(step[frames[0] - 1]):.3f} {unit}"))
    return out


def rate_mismatch(timestamps: Array, fps: float) -> Signal | None:
    """The frames whose timestamp is off `fps`'s grid (from the episode's first) by more than half a period."""
    t = np.asarray(timestamps, dtype=np.float64)
    if len(t) < 2:
        return None
    off = np.abs(t - (t[0] + np.arange(len(t)) / fps))
    frames = np.flatnonzero(~(off <= 0.5 / fps))  # NaN counts as off
    if not len(frames):
        return None
    step = float(np.median(np.diff(t)))
    rate = f"{1 / step:.3g} fps" if step > 0 else "not increasing"
    detail = (
        f"median step {step:.4f} s ({rate}), declared {fps:g} fps; frame {int(frames[0])} off by {off[frames[0]]:.4f} s"
    )
    return Signal(("timestamp",), tuple(int(f) for f in frames[:MAX_FRAMES]), len(frames), detail)


def video_disagreement(rows: int, frames: int, duration_s: float | None, fps: float) -> str | None:
    """What is wrong with an episode's video holding `frames` frames over `duration_s` for `rows` rows at `fps`
    (None when they agree: frames == rows, duration within one frame period of rows / fps)."""
    if frames != rows:
        return f"{frames} video frame(s) for {rows} row(s)"
    if duration_s is not None and abs(duration_s - rows / fps) > 1 / fps:
        return f"video lasts {duration_s:.3f} s, the rows {rows / fps:.3f} s at {fps:g} fps"
    return None
