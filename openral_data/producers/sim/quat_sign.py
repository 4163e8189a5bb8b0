"""One orientation written one way within an episode: q and -q are the same rotation, so a producer that picks
the sign per frame (e.g. always w >= 0) writes a square wave when w crosses 0 (a top-down gripper has w near 0).

The convention of every recorded quaternion [qw, qx, qy, qz]: the first frame of an episode has qw >= 0 (when
qw is 0, its first non-zero component is positive); every later frame takes the sign whose dot product with the
previous frame's quaternion is >= 0 (the sign nearest it), so consecutive quaternions never jump between q and -q.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

F64 = npt.NDArray[np.float64]
ZERO_W = 1e-12


def canonical(q: F64) -> F64:
    """The episode's first frame: qw >= 0, and when qw is 0 the first non-zero of qx, qy, qz positive."""
    lead = next((float(v) for v in q if abs(float(v)) > ZERO_W), 1.0)
    return q if lead > 0 else -q


class QuatTrack:
    """Chooses each frame's quaternion sign nearest the previous frame's; `reset()` at every episode start."""

    def __init__(self) -> None:
        self.last: F64 | None = None

    def reset(self) -> None:
        self.last = None

    def __call__(self, quat: F64) -> F64:
        q = np.asarray(quat, dtype=np.float64)
        q = canonical(q) if self.last is None else (q if float(np.dot(q, self.last)) >= 0 else -q)
        self.last = q
        return q
