"""The `mimicgen` policy: a source demonstration's segments re-targeted to the objects where they are now.

At `reset(seed)` it picks a source demonstration (seeded). Each segment starts when the previous one is spent:
the end-effector targets the source commanded over it are moved with the segment's reference object (its pose
now, composed with the inverse of its pose when the segment began in the source: the object-centric transform
of MimicGen, Mandlekar et al. 2023), reached from the current pose by a straight-line / slerp interpolation, and
played with the source's gripper commands. Each target becomes a `delta_eef_gripper` action exactly as the
scene's controller reads one (translation from the grasp site's position, rotation composed onto the
controller's accumulated orientation target), clipped to the action contract. After the last segment it holds
still, gripper as last commanded, until the scene ends the episode.
"""

from __future__ import annotations

from collections import deque
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from openral_data.errors import ConfigError
from openral_data.policies.mimicgen.plan import Demo, Plan, Segment, read_plan
from openral_data.policies.mimicgen.poses import (
    F64,
    Pose,
    compose,
    from_rotvec,
    inverse,
    quat_conj,
    quat_mul,
    slerp,
    to_rotvec,
)
from openral_data.schemas.rskill import RSkillManifest
from openral_data.types import Observation, Privileged

SALT = 0x4D494D49  # "MIMI": which source demonstration an episode replays is default_rng([seed, SALT])'s pick
MAX_STEP = 0.04  # m per interpolation step (the controller takes at most 0.05)


class MimicGenPolicy:
    def __init__(self, rskill: RSkillManifest) -> None:
        ref = rskill.policy_extras.get("plan")
        if not isinstance(ref, str) or not ref:
            raise ConfigError(f"rSkill {rskill.id}: policy_extras.plan: the plan file generate wrote is required")
        if rskill.action_contract.representation != "delta_eef_gripper":
            raise ConfigError(
                f"rSkill {rskill.id}: action_contract.representation: the mimicgen policy emits delta_eef_gripper "
                f"actions, not {rskill.action_contract.representation}"
            )
        self.plan: Plan = read_plan(Path(ref))
        c = rskill.action_contract
        self.low = np.array(c.low if c.low is not None else [-0.05] * 3 + [-0.3] * 3 + [0.0], dtype=np.float64)
        self.high = np.array(c.high if c.high is not None else [0.05] * 3 + [0.3] * 3 + [1.0], dtype=np.float64)
        self.demo: Demo = self.plan.demos[0]
        self._reset_state()

    def _reset_state(self) -> None:
        self.k = -1  # the segment being played
        self.queue: deque[tuple[Pose, float]] = deque()
        self.q_cmd: F64 | None = None  # the controller's orientation target, as this policy has moved it
        self.grip = self.demo.segments[0].gripper[0]
        self.played: list[dict[str, Any]] = []

    def reset(self, seed: int) -> None:
        rng = np.random.default_rng([seed, SALT])
        self.demo = self.plan.demos[int(rng.integers(len(self.plan.demos)))]
        self._reset_state()

    def step(self, observation: Observation, instruction: str) -> npt.NDArray[np.float32]:
        priv = observation.privileged
        ee_pos = np.asarray(priv["ee_pos"], dtype=np.float64)
        if self.q_cmd is None:
            self.q_cmd = np.asarray(priv["ee_quat"], dtype=np.float64)  # the controller starts from it too
        while not self.queue and self.k + 1 < len(self.demo.segments):
            self.k += 1
            self._start_segment(self.demo.segments[self.k], priv, ee_pos)
        if not self.queue:  # every segment played: hold still
            return self._action(np.zeros(3), np.zeros(3), self.grip)
        (pos, quat), grip = self.queue.popleft()
        self.grip = grip
        dpos = pos - ee_pos
        drot = to_rotvec(quat_mul(quat, quat_conj(self.q_cmd)))
        return self._action(dpos, drot, grip)

    def _action(self, dpos: F64, drot: F64, grip: float) -> npt.NDArray[np.float32]:
        act = np.clip(np.concatenate([dpos, drot, [grip]]), self.low, self.high)
        assert self.q_cmd is not None
        q = quat_mul(from_rotvec(act[3:6]), self.q_cmd)
        self.q_cmd = q / np.linalg.norm(q)
        return act.astype(np.float32)

    def _start_segment(self, seg: Segment, priv: Privileged, ee_pos: F64) -> None:
        info = priv.get("objects", {}).get(seg.object)
        if info is None:
            raise ConfigError(f"{self.plan.source}: plan: segment object {seg.object!r} is not in this scene")
        now: Pose = (np.asarray(info["pos"], dtype=np.float64), np.asarray(info["quat"], dtype=np.float64))
        moved = compose(now, inverse(seg.object_pose()))
        targets = [compose(moved, t) for t in seg.targets()]
        assert self.q_cmd is not None
        first_pos, first_quat = targets[0]
        angle = float(np.linalg.norm(to_rotvec(quat_mul(first_quat, quat_conj(self.q_cmd)))))
        n = max(self.plan.interpolation, int(np.ceil(float(np.linalg.norm(first_pos - ee_pos)) / MAX_STEP)))
        n = max(n, int(np.ceil(angle / 0.25)))
        for i in range(1, n + 1):
            a = i / (n + 1)
            self.queue.append(((ee_pos + a * (first_pos - ee_pos), slerp(self.q_cmd, first_quat, a)), self.grip))
        self.queue.extend(zip(targets, seg.gripper, strict=True))
        self.played.append({"segment": self.k, "object": seg.object, "source_frames": [seg.start, seg.end]})

    def episode_info(self) -> dict[str, Any]:
        """Provenance of the episode just played: the source episode and the segments taken from it."""
        return {
            "generated": {
                "source": self.plan.source,
                "source_episode": self.demo.episode,
                "segments": list(self.played),
            }
        }

    def close(self) -> None:
        pass
