"""The quality measures' thresholds and the camera stride, one place (docs/stats.md, "Quality").

Motion is measured in each dimension's dataset range (its observed max - min over every frame of the dataset),
so one threshold fits joints in radians, grippers in millimetres and end-effector poses in metres alike.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import asdict, dataclass, fields, replace
from pathlib import Path
from typing import Any

from openral_data.errors import OpenralError, UsageError
from openral_data.formats.lerobot_v3.provenance import read_provenance


@dataclass(frozen=True)
class Thresholds:
    idle_speed: float = 0.02  # a frame is idle when state and action move less than this (range / second)
    idle_flag: float = 0.5  # `idle` when at least this share of the episode's frames is idle
    idle_edge: float = 0.18  # ... or when its idle head or tail alone is at least this share of its frames
    frozen_min_frames: int = 10  # a state dimension held bit for bit this many frames while it should move
    jerk_window_s: float = 2.0  # `jerky`: windows this long (s)...
    jerk_step: float = 0.002  # ... counting steps larger than this (range units) on both sides of a frame...
    jerk_min_reversals: int = 6  # ... with at least this many that reverse direction...
    jerk_reversal_share: float = 0.5  # ... and at least this share of the counted ones (noise: about 2/3)
    chatter_hz: float = 1.0  # `chatter` when the gripper toggles at least this often per second...
    chatter_min_toggles: int = 4  # ... and at least this many times in the episode
    clip_plateau: int = 3  # a state flat top on its observed min/max for this many frames in a row is clipped
    clip_flag: float = 0.1  # `clipped` when this share of the frames is clipped
    gap_frames: float = 1.5  # a timestamp step longer than this many frame periods (or not forward) is a gap
    jitter_flag: float = 0.25  # `jitter` when a step (gaps aside) is off 1/fps by more than this many periods
    black_luma: float = 10.0  # a sampled camera frame is black below this mean luma (0-255)...
    saturated_luma: float = 240.0  # ... saturated above this one
    frozen_diff: float = 0.5  # ... frozen when its mean absolute luma difference to the previous sample is below
    blur_var: float = 10.0  # ... blurred when the variance of its Laplacian is below this
    flat_std: float = 4.0  # ... and neither frozen nor blurred when flat: its luma's standard deviation below this
    camera_flag: float = 0.1  # a camera flag is raised when this share of the sampled frames has the fault
    camera_run_frames: int = 9  # ... or a run of frozen (while the robot moves) or blurred samples spans this many
    flip_margin: float = 0.15  # `camera_flipped`: correlation with the others' picture turned 180° minus as it is
    quat_norm: float = 0.05  # `quat_norm`: a quaternion whose norm is off 1 by more than this
    teleport_step: float = 0.05  # `teleport`: a state dimension moving more than this share of its range in a frame
    teleport_factor: float = 5.0  # ... and more than this many times its local speed (median step nearby)
    drop_factor: float = 4.5  # `frame_drop`: state and action both stepping this many times their neighbours' steps
    # `frame_drop` where a motion starts: the state's step onto its command's first frame this many times its steps
    # after (`leads`); 1e9: not checked (a person's or a policy's command has no rest to start from)
    lead_factor: float = 1e9
    degrees_limit: float = 6.8  # `degrees`: an angle-named state dimension beyond ± this (rad; 2π + 0.5) is not radians
    action_lag_frames: int = 6  # `action_lag`: the state following the action more than this many frames off
    velocity_lag_frames: int = 4  # ... of a velocity/delta command, which the state follows at once (no servo)
    repeat_max: int = 4  # `repeated_rows`: state and action repeated bit for bit for 1..this many frames mid-motion
    length_ratio: float = 4.0  # `length_outlier`: an episode this many times longer or shorter than the median
    limit_margin: float = 0.02  # `joint_limit`: a joint beyond its manifest limits by this share of their range
    velocity_factor: float = 1.5  # `joint_velocity`: a joint faster than this many times its manifest velocity limit

    def as_json(self) -> dict[str, Any]:
        return asdict(self)


DEFAULT = Thresholds()
DEFAULT_STRIDE = 5  # every 5th frame of each camera is measured (all frames are decoded, codecs need them)

# Who made the data (`data_kind`) and the thresholds that differ for it. A person's hand trembles and pauses; a
# random policy's actions are noise by construction (reversals and gripper toggles are what it is, not a fault);
# a scripted expert and a trained policy take the defaults.
KINDS: dict[str, dict[str, float | int]] = {
    "default": {},
    # calibrated (benchmarks/calibrate_quality.py)
    "scripted": {"idle_flag": 0.125, "action_lag_frames": 4, "lead_factor": 1.0},
    "policy": {},
    # calibrated: a hand trembles and pauses; a real arm's encoders hold a reading for up to 11 frames where it
    # turns back (an injected clip lasts 20 frames or more)
    "person": {"jerk_reversal_share": 0.6, "idle_flag": 0.15, "clip_plateau": 12},
    # the mock scene's random rSkill writes its step counter into a state dimension named as a joint (beyond the
    # mock arm's joint limits and velocity)
    "random": {
        "jerk_min_reversals": 10**9,
        "chatter_min_toggles": 10**9,
        "degrees_limit": 1e9,
        "limit_margin": 1e9,
        "velocity_factor": 1e9,
    },
}
# rSkill policies that follow a script
SCRIPTED = ("scripted", "metaworld_expert", "maniskill_expert", "sweep", "zero", "mimicgen")


def data_kind(root: Path) -> str:
    """The kind of data `root` holds, from its provenance (meta/openral.json, the recorded rSkill's `policy`):
    `scripted`, `person` (teleoperation), `random`, `policy`; `default` without one (a foreign dataset: our
    provenance is an extra, never a precondition)."""
    try:
        provenance = read_provenance(root)
    except OpenralError:
        return "default"
    origin = provenance.origin if provenance is not None else None
    config = origin.rskill.config if origin is not None and origin.rskill is not None else None
    policy = config.get("policy") if config is not None else None
    if not isinstance(policy, str):
        return "default"
    if policy == "teleop":
        return "person"
    if policy == "random":
        return "random"
    return "scripted" if policy.startswith(SCRIPTED) else "policy"


def for_kind(th: Thresholds, kind: str) -> Thresholds:
    """`th` with `kind`'s thresholds where `th` keeps the default (a value the user set wins)."""
    changes = {k: v for k, v in KINDS.get(kind, {}).items() if getattr(th, k) == getattr(DEFAULT, k)}
    return replace(th, **changes)  # type: ignore[arg-type]  # KINDS' values have their fields' types


def parse_thresholds(pairs: Sequence[str], base: Thresholds = DEFAULT) -> Thresholds:
    """`--threshold NAME=VALUE` (repeatable; NAME a field above, spelt with `-` or `_`) -> `base` with those
    values; one line for an unknown name or a value that is not a finite number >= 0 (an integer for
    an integer field)."""
    kinds = {f.name: f.type for f in fields(Thresholds)}
    changes: dict[str, float | int] = {}
    for pair in pairs:
        name, sep, text = pair.partition("=")
        name = name.strip().replace("-", "_")
        if not sep or name not in kinds:
            raise UsageError(f"--threshold: {pair!r} is not NAME=VALUE with NAME one of {', '.join(kinds)}")
        try:
            value: float | int = int(text) if kinds[name] in (int, "int") else float(text)
        except ValueError:
            raise UsageError(
                f"--threshold: {name}: {text!r} is not a{'n integer' if kinds[name] in (int, 'int') else ' number'}"
            ) from None
        if not math.isfinite(value) or value < 0:
            raise UsageError(f"--threshold: {name}: {text!r} must be a finite number >= 0")
        changes[name] = value
    return replace(base, **changes)  # type: ignore[arg-type]  # each value parsed as its field's type above
