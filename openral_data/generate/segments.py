"""A traced source episode cut into object-centric segments (MimicGen's subtasks), each with the end-effector
targets the source commanded over it.

Boundaries (without an annotation): a segment ends `settle` frames after each gripper close (the grasp has
closed by then), the last one at the episode's end. Reference object: a segment that ends in a grasp is relative
to the object nearest the grasp site when the gripper closed; the last segment to the object nearest the grasp
site when the gripper opened after that (or at the end), other than the one held; with no grasp at all, to the
object that moved the most (what a push pushed). An annotation gives (end, object) pairs instead.

Commanded targets follow the `delta_eef_gripper` controller (producers/sim/mujoco/controllers.py): the position
target is the grasp site's position plus the clipped translation, the orientation target the clipped rotation
composed onto the previous target (starting from the orientation at the first frame).
"""

from __future__ import annotations

import numpy as np

from openral_data.errors import GenerateError
from openral_data.generate.trace import Trace
from openral_data.policies.mimicgen.plan import Segment
from openral_data.policies.mimicgen.poses import F64, from_rotvec, quat_mul

MAX_TRANSLATION, MAX_ROTATION = 0.05, 0.3  # the controller's clipping (EefDeltaController defaults)
GRIP = 6  # the gripper command's column in a delta_eef_gripper action


def targets(tr: Trace) -> tuple[list[F64], list[F64]]:
    pos: list[F64] = []
    quat: list[F64] = []
    q = tr.ee_quat[0]
    for p, a in zip(tr.ee_pos, tr.actions, strict=True):
        act = a.astype(np.float64)
        pos.append(p + np.clip(act[:3], -MAX_TRANSLATION, MAX_TRANSLATION))
        rot = act[3:6]
        angle = float(np.linalg.norm(rot))
        if angle > MAX_ROTATION:
            rot = rot * (MAX_ROTATION / angle)
        q = quat_mul(from_rotvec(rot), q)
        q = q / np.linalg.norm(q)
        quat.append(q)
    return pos, quat


def events(tr: Trace) -> tuple[list[int], list[int]]:
    """Frames where the gripper command closes / opens."""
    closed = [float(a[GRIP]) > 0.5 for a in tr.actions]
    close = [t for t in range(1, len(closed)) if closed[t] and not closed[t - 1]]
    opened = [t for t in range(1, len(closed)) if closed[t - 1] and not closed[t]]
    return close, opened


def _nearest(tr: Trace, t: int, exclude: set[str]) -> str:
    ee = tr.ee_pos[t]
    names = sorted(n for n in tr.movable | set(tr.objects[t]) if n not in exclude and not n.startswith("distractor_"))
    if not names:
        raise GenerateError(f"episode {tr.episode}: no object to re-target a segment to", code="generate.segments")
    return min(names, key=lambda n: float(np.linalg.norm(tr.objects[t][n][0] - ee)))


def _moved_most(tr: Trace) -> str:
    return max(sorted(tr.movable), key=lambda n: float(np.linalg.norm(tr.objects[-1][n][0] - tr.objects[0][n][0])))


def cuts(tr: Trace, settle: int) -> list[tuple[int, str]]:
    """(end, reference object) of each segment, ends ascending, the last at the episode's end."""
    close, opened = events(tr)
    out: list[tuple[int, str]] = []
    held: set[str] = set()
    for c in close:
        end = min(c + settle, tr.length)
        if out and end <= out[-1][0]:
            continue
        name = _nearest(tr, c, set())
        out.append((end, name))
        held = {name}
    if out and out[-1][0] >= tr.length:
        return out
    if not close:
        if not tr.movable:
            raise GenerateError(f"episode {tr.episode}: no movable object", code="generate.segments")
        return [(tr.length, _moved_most(tr))]
    after = [t for t in opened if t > close[-1]]
    out.append((tr.length, _nearest(tr, after[0] if after else tr.length - 1, held)))
    return out


def segments(tr: Trace, plan_cuts: list[tuple[int, str]]) -> list[Segment]:
    pos, quat = targets(tr)
    out: list[Segment] = []
    start = 0
    for end, name in plan_cuts:
        if name not in tr.objects[start]:
            raise GenerateError(
                f"episode {tr.episode}: segment object {name!r} is not in the source scene", code="generate.segments"
            )
        opos, oquat = tr.objects[start][name]
        out.append(
            Segment(
                start=start,
                end=end,
                object=name,
                object_pos=tuple(float(v) for v in opos),
                object_quat=tuple(float(v) for v in oquat),
                target_pos=[tuple(float(v) for v in p) for p in pos[start:end]],
                target_quat=[tuple(float(v) for v in q) for q in quat[start:end]],
                gripper=[float(a[GRIP]) for a in tr.actions[start:end]],
            )
        )
        start = end
    return out
