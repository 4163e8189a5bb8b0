"""Hidden frame drops where a scripted motion starts (`frame_drop` from `metrics/quality/leads.py`, issue 46): the
state moving before its command. Measured on a real scripted expert (tabletop_stack, MuJoCo physics, `record`):
frames lost where its lift starts after the grasp are found at the frame after the cut, about the lifting
dimension; the recording as it is raises no `frame_drop`. A settling arm, a command starting where the state
follows it, and a person's data (no `lead_factor`) raise none."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from openral_data.formats.lerobot_v3.features import STATE
from openral_data.metrics.quality import DEFAULT, leads
from openral_data.metrics.quality.thresholds import for_kind
from tests.support import data_faults as df
from tests.support.cli import run_cli

SCRIPTED = for_kind(DEFAULT, "scripted")
LOST = 5  # frames removed, as the calibration's dropped_frames on an episode this short


@pytest.mark.slow
def test_frames_lost_where_a_scripted_lift_starts_are_found(tmp_path: Path) -> None:
    """The stack expert grasps (its arm command all 0 while the gripper closes), then lifts (delta_z 0.02 a
    frame). Frames `onset` .. `onset` + 4 removed, timestamps even: the state's step onto the new frame `onset`
    carries the lift's first steps while the command before it still rests. Found there, about `eef_z`; the
    recording as it is raises no `frame_drop`; under a person's thresholds the command is left aside (the
    pictures see this cut)."""
    root = tmp_path / "stack"
    args = ["--scene", "tabletop_stack", "--n-episodes", "1", "--seed", "100", "--codec", "h264", "--out", str(root)]
    done = run_cli("record", *args)
    assert done.returncode == 0, done.stderr
    clean = df.load(root, 0, max_side=64)
    z = clean.action_names.index("delta_z")
    rest = np.abs(clean.action[:, :6]).max(axis=1) == 0  # the arm's command at rest: the grasp
    onset = next(t for t in range(1, clean.n) if rest[t - 1] and clean.action[t, z] > 0)
    assert 10 < onset < clean.n - 20, onset
    cut = clean.rows(np.r_[np.arange(onset), np.arange(onset + LOST, clean.n)])
    ds = df.write(tmp_path / "ds", [clean, cut])
    got = df.findings(ds, SCRIPTED, 5)
    drops = {e: [(f["subject"], f["start_frame"]) for f in fs if f["check"] == "frame_drop"] for e, fs in got.items()}
    assert not drops.get(0), got.get(0)
    assert drops.get(1) == [(f"{STATE}[eef_z]", onset)], got.get(1)
    # a person's thresholds leave the command aside: only the pictures' witness (`cuts`) sees this cut
    person = df.findings(df.write(tmp_path / "person", [cut]), for_kind(DEFAULT, "person"), 5)
    seen = [(f["subject"], f["start_frame"]) for f in person.get(0, []) if f["check"] == "frame_drop"]
    assert seen and all(subject.startswith("observation.images.") for subject, _ in seen), seen


def _arm(command: np.ndarray, drift: float = 0.0) -> np.ndarray:
    """A delta controller's state: each step follows the command of the frame before, 0.75 of it at once and the
    rest a frame later (the arm's inertia), plus `drift` a frame while the command rests (settling)."""
    s = np.zeros(len(command))
    for t in range(1, len(command)):
        s[t] = s[t - 1] + 0.75 * command[t - 1] + 0.25 * (command[t - 2] if t > 1 else 0.0)
        s[t] += drift if command[t - 1] == 0 else 0.0
    return s


def test_the_state_following_its_command_or_settling_is_no_drop() -> None:
    """One dimension commanded 0 for 20 frames then 0.02 a frame: the state follows a frame later, no finding;
    settling by a tenth of the motion's step while the command rests, none; 4 frames lost from the command's
    start, a `frame_drop` at the cut; with `lead_factor` off (the default: a person's or a policy's data), none."""
    command = np.r_[np.zeros(20), np.full(30, 0.02)]
    names = (["delta_z"], ["eef_z"])
    late = np.zeros(len(command) - 1, dtype=bool)

    def found(cmd: np.ndarray, state: np.ndarray, factor: float = SCRIPTED.lead_factor) -> list[tuple[str, int]]:
        got = leads.frame_drops(cmd[:, None], state[:, None], names, late[: len(cmd) - 1], factor)
        return [(f.subject, f.start_frame or 0) for f in got]

    assert found(command, _arm(command)) == []
    assert found(command, _arm(command, drift=0.0015)) == []
    kept = np.r_[np.arange(20), np.arange(24, len(command))]
    assert found(command[kept], _arm(command)[kept]) == [(f"{STATE}[eef_z]", 20)]
    assert found(command[kept], _arm(command)[kept], DEFAULT.lead_factor) == []
