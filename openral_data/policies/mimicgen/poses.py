"""Rigid poses as (position[3], quaternion[4] as w, x, y, z), the conventions MuJoCo and our states use."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

F64 = npt.NDArray[np.float64]
Pose = tuple[F64, F64]


def quat_mul(a: F64, b: F64) -> F64:
    aw, ax, ay, az = a
    bw, bx, by, bz = b
    return np.array(
        [
            aw * bw - ax * bx - ay * by - az * bz,
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
        ]
    )


def quat_conj(q: F64) -> F64:
    return np.array([q[0], -q[1], -q[2], -q[3]])


def rotate(q: F64, v: F64) -> F64:
    return quat_mul(quat_mul(q, np.array([0.0, *v])), quat_conj(q))[1:]


def from_rotvec(r: F64) -> F64:
    angle = float(np.linalg.norm(r))
    if angle < 1e-12:
        return np.array([1.0, 0.0, 0.0, 0.0])
    return np.array([np.cos(angle / 2), *(np.sin(angle / 2) * r / angle)])


def to_rotvec(q: F64) -> F64:
    """The rotation vector of `q` (the shorter way round)."""
    q = q if q[0] >= 0 else -q
    s = float(np.linalg.norm(q[1:]))
    if s < 1e-12:
        return np.zeros(3)
    out: F64 = 2.0 * np.arctan2(s, q[0]) * q[1:] / s
    return out


def compose(a: Pose, b: Pose) -> Pose:
    """a * b: `b` expressed in `a`'s frame, taken to the world."""
    return a[0] + rotate(a[1], b[0]), quat_mul(a[1], b[1])


def inverse(a: Pose) -> Pose:
    qi = quat_conj(a[1])
    return -rotate(qi, a[0]), qi


def slerp(a: F64, b: F64, t: float) -> F64:
    if float(a @ b) < 0:
        b = -b
    return quat_mul(a, from_rotvec(t * to_rotvec(quat_mul(quat_conj(a), b))))
