"""`robosuite` scenes: robosuite 1.5.1 manipulation tasks (Lift, Stack, PickPlaceCan, Door, ...) as a SimRollout.

The robot is fixed by the scene: robosuite's Panda for the `franka_panda` manifest, or one of the multi-part
robots robosuite-models 1.0.0 registers (Unitree G1 and H1, Fourier GR1, ALOHA: `ROBOTS`), all under robosuite's
BASIC composite controller (GR1's own default, whole-body IK, needs `mink`). A multi-part robot's state and action
are named part by part (robosuite_body.py): the state `joint_positions_gripper` (every body joint, then every
finger joint), the action `generic` (per arm OSC_POSE deltas, torso/head/legs joint deltas, per hand the gripper
action), and its robot manifest and the rSkill contract must name them as robosuite's robot has them.

The Panda is driven by robosuite's OSC_POSE arm controller: the action is robosuite's own normalised 7-vector
[dx, dy, dz, dax, day, daz, gripper] in [-1, 1] (scaled by the controller to at most 5 cm and 0.5 rad per step;
gripper -1 open .. +1 closed), stored exactly as the policy emitted it.
The control rate is the scene's `fps` (robosuite's `control_freq`).

Observation state, by the rSkill state contract's representation:
* `eef_pose_gripper` (8): end-effector [x, y, z] + quaternion [qw, qx, qy, qz] (world frame; sign continuous
  within an episode, qw >= 0 on its first frame: quat_sign.py) + gripper
  closure (0 open .. 1 closed, from the finger joints)
* `joint_positions_gripper` (n + 1): arm joint positions + gripper closure
Success is the task's own `_check_success()`; the reward is robosuite's sparse task reward. Object observations
and every task object's pose (`object_poses`, also in `initial_state()`, which replay compares) go to
`Observation.privileged` and are never recorded. `Observation.time` is simulation time
since reset. Cameras are the model's named cameras (`agentview`, `robot0_eye_in_hand`, ...), rendered upright by
our own offscreen renderers (so resolution and shadows come from the YAML).

Seeds: robosuite draws object placements and joint noise from numpy's global generator; `reset(seed)` seeds it
for the duration of the reset only (the caller's global random state is put back), so a seed is one initial
state. `reset_to` repeats that reset and checks it reproduces the recorded MuJoCo state (see mjstate.py).
"""

from __future__ import annotations

import logging
import random
import warnings
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any, Literal, cast

import numpy as np
import numpy.typing as npt
from pydantic import Field

import openral_data.producers.sim.mujoco  # noqa: F401  (chooses a headless MUJOCO_GL before mujoco loads)
from openral_data.errors import ConfigError, install_hint
from openral_data.producers.sim import mjstate
from openral_data.producers.sim.contract import check_representations, scene_spec
from openral_data.producers.sim.initial_state import check_recorded_on
from openral_data.producers.sim.mujoco.rig_scene import RigScene
from openral_data.producers.sim.named_cameras import named_camera_rig
from openral_data.producers.sim.params import parse_params
from openral_data.producers.sim.quat_sign import QuatTrack
from openral_data.producers.sim.robosuite_body import BodyLayout, check_contract, check_manifest, layout, state_vector
from openral_data.producers.sim.tasks import SuiteTask
from openral_data.schemas.base import StrictModel
from openral_data.schemas.robot import RobotManifest
from openral_data.schemas.rskill import RSkillManifest
from openral_data.schemas.scene import SimScene
from openral_data.types import Observation, Privileged, StepResult

STATE_FORMAT = 1
STATE_REPRESENTATIONS = ("eef_pose_gripper", "joint_positions_gripper")
ACTION_REPRESENTATIONS = ("delta_eef_gripper",)
# our manifest -> robosuite robot name (the multi-part ones registered by robosuite-models' import in robosuite)
ROBOTS = {
    "franka_panda": "Panda",
    "unitree_g1": "G1",
    "unitree_h1": "H1",
    "fourier_gr1": "GR1",
    "robosuite_aloha": "Aloha",
}
BODY_STATE_REPRESENTATIONS = ("joint_positions_gripper",)
BODY_ACTION_REPRESENTATIONS = ("generic",)
GRIPPER_OPEN_WIDTH = 0.08  # Panda fingers: 2 x 4 cm
# robosuite's geom groups: 0 collision, 1 visual, 2 controller target markers (never drawn). With
# `render.robot_meshes: collision` (the default) the robot's visual meshes (~50 detailed meshes, ~4x slower on a
# CPU renderer) move to group 3 and its collision geoms to group 4, which is drawn with everything's visual group.
ROBOT_BODY_PREFIXES = ("robot0_", "gripper0_", "fixed_mount0_", "mount0_")
VISUAL, HIDDEN_ROBOT_VISUAL, ROBOT_COLLISION = 1, 3, 4


RobosuiteEnv = Literal[
    "Lift", "Stack", "PickPlaceCan", "PickPlaceMilk", "PickPlaceBread", "PickPlaceCereal", "Door", "NutAssemblyRound"
]
# robosuite has no language: each environment's instruction (the shipped scenes' where they have one)
INSTRUCTIONS: dict[RobosuiteEnv, str] = {
    "Lift": "lift the red cube off the table",
    "Stack": "stack the red cube on the green cube",
    "PickPlaceCan": "pick the can and place it in its bin",
    "PickPlaceMilk": "pick the milk carton and place it in its bin",
    "PickPlaceBread": "pick the bread and place it in its bin",
    "PickPlaceCereal": "pick the cereal box and place it in its bin",
    "Door": "open the door",
    "NutAssemblyRound": "fit the round nut onto the round peg",
}


def suite_tasks(scene: SimScene, source: str) -> list[SuiteTask]:
    """The robosuite environments this adapter drives (`--task Stack`); robot and controller stay the scene's."""
    return [SuiteTask(name, text, {"env": name}) for name, text in INSTRUCTIONS.items()]


class RobosuiteParams(StrictModel):
    env: RobosuiteEnv = Field(description="robosuite environment name")
    controller: Literal["OSC_POSE"] = "OSC_POSE"
    terminate_on_success: bool = True


@contextmanager
def _seeded_global_numpy(seed: int) -> Iterator[None]:
    """robosuite draws from numpy's (and Python's) global generators: seed both for one reset or construction,
    then put back the caller's states."""
    saved, saved_py = np.random.get_state(), random.getstate()
    np.random.seed(seed)
    random.seed(seed)
    try:
        yield
    finally:
        np.random.set_state(saved)
        random.setstate(saved_py)


def _quiet(record: logging.LogRecord) -> bool:
    return record.levelno >= logging.ERROR


def _import_robosuite() -> Any:
    """Import robosuite without its console chatter: at import it warns about optional packages we do not use
    (robosuite_models, mink) and per environment about controller parts the Panda lacks; errors still show."""
    logger = logging.getLogger("robosuite_logs")
    if _quiet not in logger.filters:
        logger.addFilter(_quiet)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # SyntaxWarnings from robosuite's docstrings when compiled
            import robosuite
    except ImportError:
        raise ConfigError(
            f"robosuite scenes need the 'robosuite' extra (robosuite 1.5.1, mujoco 3.3.0): {install_hint('robosuite')}"
        ) from None
    return robosuite


class RobosuiteScene(RigScene):
    """One robosuite environment, built once; `reset(seed)` per episode; `close()` frees renderers."""

    def __init__(
        self, scene: SimScene, robot: RobotManifest, rskill: RSkillManifest, source: str, rskill_source: str
    ) -> None:
        self._check_scene(scene, robot, rskill, source, rskill_source)
        self.env: Any = self._make_env(scene, robot)
        self.env_name = self.params.env
        self._obs: dict[str, Any] = {}
        self._quat_track = QuatTrack()
        self.model = self.env.sim.model._model
        self.data = self.env.sim.data._data
        self._objects = {o.name: self.model.body(o.root_body).id for o in self.env.model.mujoco_objects}
        with _seeded_global_numpy(0):
            self._obs = self.env.reset()
        self.body: BodyLayout | None = None
        if robot.name != "franka_panda":
            self.body = layout(self.env.robots[0], self.env.sim.model)
            check_manifest(self.body, robot, f"robot {robot.name!r}")
            state_dim = len(self.body.state_names)
        else:
            n_arm = len(self._obs["robot0_joint_pos"])
            state_dim = 8 if self.state_representation == "eef_pose_gripper" else n_arm + 1
        self.task_text = scene.task.instruction
        self._seed = 0
        self.initial = {}
        self._wire_cameras(scene, source, state_dim)

    def _check_scene(
        self, scene: SimScene, robot: RobotManifest, rskill: RSkillManifest, source: str, rskill_source: str
    ) -> None:
        """The scene's params, a robot robosuite has, the rSkill's representations, an fps robosuite can step."""
        self.params = parse_params(RobosuiteParams, scene, source)
        if robot.name not in ROBOTS:
            raise ConfigError(
                f"{source}: scene.robot: robosuite scenes support {', '.join(ROBOTS)}, got {robot.name!r}"
            )
        self.state_representation = rskill.state_contract.representation
        if robot.name == "franka_panda":
            check_representations(
                rskill,
                rskill_source,
                "robosuite scenes",
                STATE_REPRESENTATIONS,
                ACTION_REPRESENTATIONS,
                accepted_note=": robosuite's normalised OSC_POSE action",
            )
        else:
            check_representations(
                rskill,
                rskill_source,
                f"robosuite's {ROBOTS[robot.name]}",
                BODY_STATE_REPRESENTATIONS,
                BODY_ACTION_REPRESENTATIONS,
                accepted_note=": its composite controller's action, named part by part",
            )
            check_contract(robot, rskill, rskill_source)
        if 500 % scene.scene.fps:
            raise ConfigError(
                f"{source}: scene.fps: must divide robosuite's 500 Hz physics rate, got {scene.scene.fps}"
            )

    def _make_env(self, scene: SimScene, robot: RobotManifest) -> Any:
        """The robosuite environment, made once under a fixed seed."""
        suite = _import_robosuite()
        from robosuite.controllers import load_composite_controller_config
        from robosuite.robots import REGISTERED_ROBOTS

        rs_robot = ROBOTS[robot.name]
        if rs_robot not in REGISTERED_ROBOTS:  # robosuite registers robosuite-models' robots when it is installed
            raise ConfigError(
                f"robot {robot.name!r}: robosuite's {rs_robot} comes from robosuite-models 1.0.0, not installed: "
                + install_hint("robosuite")
            )
        config = load_composite_controller_config(controller="BASIC", robot=rs_robot)
        # robosuite also draws at construction (Lift's cube size, for one): a fixed seed makes the model the same
        # in every process, so a recorded state can be reproduced by `replay` elsewhere
        with _seeded_global_numpy(0):
            return suite.make(
                self.params.env,
                robots=rs_robot,
                controller_configs=config,
                has_renderer=False,
                has_offscreen_renderer=False,  # we render the named cameras ourselves (see named_cameras.py)
                use_camera_obs=False,
                use_object_obs=True,
                control_freq=scene.scene.fps,
                horizon=1_000_000,  # episode length is record's --max-steps
                ignore_done=True,
                hard_reset=False,  # keep one compiled model: resets only re-place objects (and stay restorable)
                reward_shaping=False,
            )

    def _wire_cameras(self, scene: SimScene, source: str, state_dim: int) -> None:
        """The named cameras (the robot drawn coarse when asked) and the spec the recording sees."""
        groups: tuple[int, ...] = (VISUAL,)
        if scene.scene.render.robot_meshes == "collision":
            self._coarse_robot()
            groups = (VISUAL, ROBOT_COLLISION)
        self.rig = named_camera_rig(
            self.model, self.data, list(scene.scene.cameras), scene.scene.render, source, geom_groups=groups
        )
        if scene.scene.observations.environment_state:
            self.environment_objects = tuple(self._objects)
        self.spec = scene_spec(
            state_dim,
            int(self.env.action_dim),
            scene.scene.cameras,
            scene.scene.fps,
            shapes=self.rig.shapes(),
            environment_objects=self.environment_objects,
        )

    # -- SimRollout ------------------------------------------------------------------------------------------
    def reset(self, seed: int) -> Observation:
        self._seed = seed
        with _seeded_global_numpy(seed):
            self._obs = self.env.reset()
        self.t0 = float(self.data.time)
        self.initial = {
            "format": STATE_FORMAT,
            "suite": "robosuite",
            "env": self.env_name,
            "seed": seed,
            "object_poses": {k: v.tolist() for k, v in self._object_poses().items()},
            "mujoco": mjstate.snapshot(self.model, self.data),
        }
        self._quat_track.reset()
        return self._observation()

    def reset_to(self, initial_state: dict[str, Any]) -> Observation:
        """Repeat the recorded seed's reset and check that it lands on the recorded MuJoCo state, bit for bit.

        robosuite keeps controller and observable state in Python next to MuJoCo's (refreshing its observables
        alone changes the following steps), so a state is restored by reproducing it, not by writing it: a
        recorded state this robosuite does not reproduce from its seed is refused.
        """
        if initial_state.get("format") != STATE_FORMAT or initial_state.get("suite") != "robosuite":
            raise ConfigError(f"initial_state: format: not a robosuite state of format {STATE_FORMAT}")
        check_recorded_on(initial_state, "env", self.env_name)
        seed = int(initial_state.get("seed", 0))
        obs = self.reset(seed)
        if not mjstate.same_state(self.initial["mujoco"], initial_state.get("mujoco", {})):
            raise ConfigError(
                f"initial_state: mujoco: robosuite's reset with seed {seed} does not reproduce the recorded state "
                "(recorded with another robosuite/mujoco version or scene?)"
            )
        return obs

    def step(self, action: npt.NDArray[np.float32]) -> StepResult:
        self._obs, reward, _, _ = self.env.step(np.asarray(action, dtype=np.float64))
        success = bool(self.env._check_success())
        return StepResult(
            self._observation(),
            reward=float(reward),
            success=success,
            terminated=success and self.params.terminate_on_success,
        )

    # -- helpers ---------------------------------------------------------------------------------------------
    def _coarse_robot(self) -> None:
        """Draw the robot with its collision geoms (geom groups only affect drawing, never physics)."""
        m = self.model
        for g in range(m.ngeom):
            if m.body(m.geom_bodyid[g]).name.startswith(ROBOT_BODY_PREFIXES):
                m.geom_group[g] = HIDDEN_ROBOT_VISUAL if m.geom_group[g] == VISUAL else ROBOT_COLLISION

    def _object_poses(self) -> dict[str, npt.NDArray[np.float64]]:
        """Each task object's root body: [x, y, z, qw, qx, qy, qz], world frame (replay compares them)."""
        d = self.data
        return {name: np.concatenate([d.xpos[b], d.xquat[b]]) for name, b in self._objects.items()}

    def _gripper(self) -> float:
        q = np.asarray(self._obs["robot0_gripper_qpos"], dtype=np.float64)
        width = float(q[0] - q[1])
        return float(np.clip(1.0 - width / GRIPPER_OPEN_WIDTH, 0.0, 1.0))

    def _state(self) -> npt.NDArray[np.float32]:
        o = self._obs
        if self.body is not None:
            return state_vector(o, self.body.arms)
        if self.state_representation == "joint_positions_gripper":
            joints = np.asarray(o["robot0_joint_pos"], dtype=np.float64)
            return np.append(joints, self._gripper()).astype(np.float32)
        x, y, z, w = (float(v) for v in o["robot0_eef_quat"])  # robosuite quaternions are xyzw
        quat = self._quat_track(np.array([w, x, y, z]))
        pos = np.asarray(o["robot0_eef_pos"], dtype=np.float64)
        return np.concatenate([pos, quat, [self._gripper()]]).astype(np.float32)

    def _observation(self) -> Observation:
        # the environment's own observation keys (cube_pos, ...) as they are: not all of them declared
        arms = ("",) if self.body is None else tuple(f"{a}_" for a in self.body.arms)
        # and the hand's position: the Panda's `eef_pos`; a multi-part robot's `right_eef_pos`, `left_eef_pos`
        hands = {f"{arm}eef_pos": self._obs[f"robot0_{arm}eef_pos"] for arm in arms}
        privileged = cast(
            Privileged,
            {
                k: np.array(v, dtype=np.float64)
                for k, v in (*self._obs.items(), *hands.items())
                if not k.startswith("robot0_") and not k.endswith("-state")
            },
        )
        privileged["object_poses"] = self._object_poses()
        privileged["suite"] = "robosuite"
        privileged["env"] = self.env_name
        return self.observe(self._state(), privileged)
