"""Hidden frame drops the state's rows show (`frame_drop`, issue 46, h-drops3), through `episode.row_findings`
(the rows' rules as the engine runs them): frames lost where one dimension moves quickly inside the cut (each
moving dimension jumps the way it was moving: `rows.together`), and the step ratio the pictures' witness reads
measured on the position without the orientation's noise (`rows.positions`). Not drops: the same episode
without the cut, a waypoint, a pause lost and one dimension teleporting."""

from __future__ import annotations

import numpy as np

from openral_data.formats.lerobot_v3.features import STATE
from openral_data.metrics.quality import DEFAULT, cuts
from openral_data.metrics.quality.episode import row_findings

Array = np.ndarray
N, AT, LOST = 60, 25, 10  # frames; the cut: frames AT..AT+LOST-1 lost


def rows_of(z: Array, names: list[str]) -> list[tuple[str, str, int | None]]:
    found, _ = row_findings({STATE: z}, {STATE: (z, names)}, np.ones(len(z) - 1), DEFAULT)
    return sorted((f.check, f.subject, f.start_frame) for f in found)


def cut(z: Array) -> Array:
    return np.concatenate([z[:AT], z[AT + LOST :]])


def test_frames_lost_where_one_dimension_moves_quickly_are_a_frame_drop() -> None:
    """`a` and `b` move 0.01 a frame throughout; `c` creeps 0.003 a frame but moves 0.05 a frame on the 10 frames
    that are lost. At the cut every dimension steps on the way it was moving, each 10x its own speed and more,
    but the step's direction (mostly `c`'s) is not its neighbours' (cosine 0.5; rebot_b601's 15 frames lost
    where its wrist turned, 0.77): before, no finding or 3 `teleport`s; now one `frame_drop` at the cut. Kept
    whole, the quick move is no drop; a waypoint (a and b 4x faster from frame 30 on), a pause lost (10 frames
    holding still) and `a` alone jumping by 0.3 (a `teleport`) are none either."""
    t = np.arange(N, dtype=np.float64)
    burst = np.where((t >= AT) & (t < AT + LOST), 0.05, 0.003)
    c = np.concatenate([[0.0], np.cumsum(burst[:-1])])
    z = np.stack([0.01 * t, 0.01 * t, c], axis=1)
    names = ["a", "b", "c"]
    assert rows_of(cut(z), names) == [("frame_drop", STATE, AT)]
    assert rows_of(z, names) == []
    fast = np.stack([0.01 * t + 0.03 * np.maximum(t - 30, 0)] * 2 + [0.003 * t], axis=1)
    assert rows_of(fast, names) == []
    held = np.maximum(t - AT, 0) - np.clip(t - AT, 0, LOST)  # still on frames AT..AT+LOST
    pause = np.stack([0.01 * (AT + held), 0.01 * (AT + held), 0.003 * (AT + held)], axis=1)
    pause[:AT] = z[:AT]
    assert rows_of(cut(pause), names) == []
    jumped = np.stack([0.01 * t, 0.01 * t, 0.003 * t], axis=1)
    jumped[30:, 0] += 0.3
    assert rows_of(jumped, names) == [("teleport", f"{STATE}[a]", 30)]


def test_the_orientation_noise_does_not_hide_the_position_lost() -> None:
    """An end effector (x, y, z and its orientation quaternion, whose components span a few thousandths: in
    range units their noise steps 0.1-0.24 a frame, here flickering) moves 0.02 a frame in x and y. 2 frames
    lost before frame 30: the state's step ratio the pictures' witness reads (`rows.step_ratios`) is the
    position's, 3x its neighbours at the cut, reaching `cuts.STEP` (before, with the orientation in the norm:
    1.0), 1 everywhere else; the rows leave it to the pictures. 5 frames lost: x and y jump on together, a
    `frame_drop` (before: two `teleport`s). The orientation stays in the rows' spread test, so x alone jumping
    by 0.3 while the hand turns on is a `teleport`, no drop."""
    n, at = 50, 30
    t = np.arange(n + 5, dtype=np.float64)
    quat = 0.5 + np.outer((-1.0) ** t, [0.1, 0.05, 0.08, 0.12])  # in range units: noise over a tiny range
    z = np.column_stack([0.02 * t, 0.02 * t, 0.5 + 0.0 * t, quat])
    names = ["eef_x", "eef_y", "eef_z", "eef_qw", "eef_qx", "eef_qy", "eef_qz"]
    lost = np.concatenate([z[:at], z[at + 2 :]])
    found, ratios = row_findings({STATE: lost}, {STATE: (lost, names)}, np.ones(len(lost) - 1), DEFAULT)
    assert found == [] and ratios is not None
    assert ratios[at] > 2.5 and ratios[at] >= cuts.STEP
    assert np.delete(ratios, at).max() < cuts.STEP
    assert rows_of(np.concatenate([z[:at], z[at + 5 :]]), names) == [("frame_drop", STATE, at)]
    turning = np.column_stack([0.02 * t, 0.5 + 0.0 * t, 0.5 + 0.0 * t, np.outer(0.3 + 0.01 * t, np.ones(4))])[:n]
    turning[at:, 0] += 0.3
    assert rows_of(turning, names) == [("teleport", f"{STATE}[eef_x]", at)]
