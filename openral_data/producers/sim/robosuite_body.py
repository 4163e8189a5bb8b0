"""The named state and action of a robosuite robot with several parts (humanoids, bimanual arms), read from the
robosuite robot itself so that the names a robot manifest and an rSkill contract give can be checked against the
MJCF's joints and the composite controller's parts.

robosuite 1.5.1's BASIC composite controller drives each part on its own, in its action-split order:
* an arm (`right`, `left`): OSC_POSE, 6 normalised deltas in [-1, 1] (at most 5 cm / 0.5 rad per step, the base
  frame): `right_arm.dx .. right_arm.daz`
* `torso`, `head`, `legs`: JOINT_POSITION deltas in [-1, 1] (at most 0.5 rad per step), one per joint:
  `torso.<joint>`, `legs.<joint>` (the joint names say which leg)
* a hand (`right_gripper`, `left_gripper`): robosuite's gripper action in [-1, 1] (-1 open .. 1 closed); one value
  (`right_hand.grip`) for a 1-DoF gripper, else one per actuator (`right_hand.<actuator>`: the dexterous hands)

The state is every body joint's position (rad; robosuite's `robot0_joint_pos`, MJCF names without the `robot0_`
prefix) followed, per arm, by every finger joint's position (`right_hand.<joint>`, the gripper MJCF's names
without the `gripper0_right_` prefix).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from openral_data.errors import CompatibilityError, ConfigError
from openral_data.schemas.robot import RobotManifest
from openral_data.schemas.rskill import RSkillManifest

ARM_FIELDS = ("dx", "dy", "dz", "dax", "day", "daz")
ROBOT_PREFIX = "robot0_"


@dataclass(frozen=True)
class BodyLayout:
    """A multi-part robosuite robot's state and action, by name (see the module docstring)."""

    state_names: tuple[str, ...]
    action_names: tuple[str, ...]
    arms: tuple[str, ...]


def _strip(name: str, prefix: str) -> str:
    return name[len(prefix) :] if name.startswith(prefix) else name


def _joint_name(model: Any, joint: Any) -> str:
    return str(joint) if isinstance(joint, str) else str(model.joint_id2name(int(joint)))


def _part_names(robot: Any, model: Any, part: str, width: int) -> list[str]:
    """The action names of one part of the composite controller's action (`width` entries)."""
    if part in robot.arms:
        return [f"{part}_arm.{f}" for f in ARM_FIELDS]
    if part.endswith("_gripper") and part[: -len("_gripper")] in robot.arms:
        arm = part[: -len("_gripper")]
        if width == 1:
            return [f"{arm}_hand.grip"]
        prefix = f"gripper0_{arm}_"
        return [f"{arm}_hand.{_strip(a, prefix)}" for a in robot.gripper[arm].actuators[:width]]
    joints = robot.part_controllers[part].joint_index
    return [f"{part}.{_strip(_joint_name(model, j), ROBOT_PREFIX)}" for j in joints]


def layout(robot: Any, model: Any) -> BodyLayout:
    """The names robosuite's robot `robot` (a built environment's `env.robots[0]`) produces and accepts."""
    arms = tuple(str(a) for a in robot.arms)
    state = [_strip(str(j), ROBOT_PREFIX) for j in robot.robot_joints]
    for arm in arms:
        state += [f"{arm}_hand.{_strip(str(j), f'gripper0_{arm}_')}" for j in robot.gripper_joints[arm]]
    action: list[str] = []
    for part, (start, stop) in robot.composite_controller._action_split_indexes.items():
        action += _part_names(robot, model, str(part), int(stop) - int(start))
    return BodyLayout(tuple(state), tuple(action), arms)


def state_vector(obs: dict[str, Any], arms: tuple[str, ...]) -> npt.NDArray[np.float32]:
    """The state (body joints, then each arm's finger joints) from robosuite's observation dict."""
    parts = [np.asarray(obs[f"{ROBOT_PREFIX}joint_pos"], dtype=np.float64)]
    parts += [np.asarray(obs[f"{ROBOT_PREFIX}{arm}_gripper_qpos"], dtype=np.float64) for arm in arms]
    return np.concatenate(parts).astype(np.float32)


def _first_difference(expected: tuple[str, ...], given: list[str] | None, whose: str) -> str:
    got = list(given or [])
    if len(got) != len(expected):
        return f"{len(got)} names, {whose} has {len(expected)}"
    k = next(i for i, (a, b) in enumerate(zip(expected, got, strict=True)) if a != b)
    return f"entry {k} is {got[k]!r}, {whose} has {expected[k]!r} there"


def check_contract(robot: RobotManifest, rskill: RSkillManifest, rskill_source: str) -> None:
    """The rSkill's contract names the state and action as the robot manifest does (CompatibilityError)."""
    sides = (
        ("state_contract.names", robot.observation.state.names, rskill.state_contract.names),
        ("action_contract.names", robot.action.names, rskill.action_contract.names),
    )
    for field, expected, given in sides:
        if list(expected or ()) != list(given):
            problem = _first_difference(tuple(expected or ()), given, f"robot {robot.name!r}")
            raise CompatibilityError(f"{rskill_source}: {field}: {problem}")


def check_manifest(body: BodyLayout, robot: RobotManifest, robot_source: str) -> None:
    """The robot manifest names the state and action exactly as robosuite's robot has them (ConfigError)."""
    sides = (
        ("observation.state.names", robot.observation.state.names, body.state_names),
        ("action.names", robot.action.names, body.action_names),
    )
    for field, given, expected in sides:
        if tuple(given or ()) != expected:
            raise ConfigError(f"{robot_source}: {field}: {_first_difference(expected, given, "robosuite's robot")}")
