"""HALs backed by MuJoCo: the digital twin of any robot manifest, and any sim scene behind the HAL protocol.

`MujocoTwinHal` composes the manifest's arm and gripper (its `sim:` block, the same `compose` the tabletop
scenes use, no per-robot code: `producers/sim/mujoco/twin.py`'s `Twin`) on the standard table, drives it with
the same position servos (`JointPositionController`) in the manifest's units (`sim.units`: e.g. the SO arm's
degrees and 0..100 gripper, converted at this boundary) and runs physics in step with the monotonic clock:
every read or command first advances the simulation to "now" (at most `max_catch_up` seconds at once), so a
slow loop sees the robot keep moving exactly as hardware would. Cameras render on the caller's thread when sampled.

`SceneHal` puts a `SimRollout` (e.g. `tabletop_push`) behind the protocol: each command advances the scene by
one control step; reward, success and privileged ground truth are passed on for scripted experts, and the
scene's `observation.environment_state` (its object poses, when the scene declares them) for the policy and the
dataset, under the names `record --scene` gives them.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import mujoco
import numpy as np

from openral_data.errors import ConfigError
from openral_data.producers.hal.cameras.sensors import Image, PolledCamera
from openral_data.producers.hal.robots.base import F32, HalBase, JointCommand, Outcome, RobotState, monotonic
from openral_data.producers.hal.robots.safety import ForwardKinematics
from openral_data.producers.sim.mujoco.kinematics import F64
from openral_data.producers.sim.mujoco.render import CameraRig
from openral_data.producers.sim.mujoco.twin import Twin
from openral_data.schemas.robot import RobotManifest
from openral_data.schemas.scene import RenderConfig, SceneCamera
from openral_data.types import CameraShape, Observation, Privileged, SimRollout

# where a manifest's non-wrist cameras go on the twin's table (the manifest gives sizes, not poses)
DEFAULT_WORLD_CAMERA = {"pos": (1.3, 0.0, 1.4), "lookat": (0.4, 0.0, 0.85), "fovy": 45.0}


def twin_cameras(robot: RobotManifest) -> list[SceneCamera]:
    cams = []
    for c in robot.sensors.cameras:
        if c.mount == "wrist":
            cams.append(SceneCamera(name=c.name, width=c.width, height=c.height, mount="wrist"))
        else:
            cams.append(SceneCamera(name=c.name, width=c.width, height=c.height, **DEFAULT_WORLD_CAMERA))
    return cams


class MujocoTwinHal(HalBase):
    """The robot of any manifest with a `sim:` block, simulated in real time, in the manifest's units."""

    def __init__(
        self,
        robot: RobotManifest,
        *,
        cameras: list[SceneCamera] | None = None,
        render: RenderConfig | None = None,
        max_catch_up: float = 0.5,
    ) -> None:
        super().__init__(robot)
        self._camera_specs = cameras if cameras is not None else twin_cameras(robot)
        self._render = render or RenderConfig()
        self.twin = Twin(robot, self._camera_specs)
        self.source = self.twin.source
        self.params = self.twin.params
        self.model = self.twin.model
        self.data = mujoco.MjData(self.model)
        self._scratch = mujoco.MjData(self.model)
        self.arm = self.twin.arm
        self.home = self.twin.home  # MJCF units (sim.home)
        self.max_catch_up = max_catch_up
        self._rig: CameraRig | None = None
        self._frames: dict[str, Image] = {}
        self._frames_time = -1.0
        self._t0 = 0.0
        for cam in self._camera_specs:
            self.cameras[cam.name] = PolledCamera(cam.name, CameraShape(cam.height, cam.width), self._grabber(cam.name))

    # -- HalBase hooks ---------------------------------------------------------------------------------------
    def _connect(self) -> None:
        self.twin.hold_home(self.data)
        self._rig = CameraRig(self.model, self._camera_specs, self._render)
        self._t0 = monotonic()

    def _disconnect(self) -> None:
        if self._rig is not None:
            self._rig.close()
            self._rig = None

    def _advance(self) -> float:
        """Step physics up to the monotonic clock; returns the time the stepped state is presented at.

        That is the clock after stepping: the simulator's own compute time is not robot latency, so it does
        not age the reading (a real bus's delay does, see `HalBase.read_state`)."""
        now = monotonic()
        behind = (now - self._t0) - self.data.time
        if behind > self.max_catch_up:  # a stalled caller: skip ahead rather than simulate a burst
            self._t0 += behind - self.max_catch_up
            behind = self.max_catch_up
        n = int(behind / self.model.opt.timestep)
        if n > 0:
            mujoco.mj_step(self.model, self.data, nstep=n)
            return monotonic()
        return now

    def _read_state(self) -> RobotState:
        stamp = self._advance()
        return RobotState(self.twin.state(self.data), stamp)

    def _send(self, command: JointCommand) -> JointCommand:
        self._advance()
        self.twin.command(self.data, command.positions)
        return command

    def _grabber(self, name: str) -> Callable[[], Image]:
        return lambda: self._grab(name)

    def _grab(self, name: str) -> Image:
        if self._rig is None:
            raise ConfigError(f"{self.source}: camera {name}: the twin is not connected")
        if self._frames_time != self.data.time:
            self._frames = self._rig.render(self.data)
            self._frames_time = float(self.data.time)
        return self._frames[name]

    # -- kinematics for the safety filter --------------------------------------------------------------------
    def base_position(self) -> F64:
        return np.array(self.data.xpos[self.twin.base_body], dtype=np.float64)

    def forward_kinematics(self, q: F64) -> F64:
        """End-effector site position for the arm joint targets in `q` (action order, manifest units), base
        frame."""
        return self.twin.forward_kinematics(self.data, self._scratch, q)

    def kinematics(self) -> ForwardKinematics:
        return self.forward_kinematics

    def begin_episode(self, seed: int) -> dict[str, Any]:
        return {"hal": "mujoco_twin", "robot": self.robot.name, "qpos": self.data.qpos.tolist()}


class SceneHal(HalBase):
    """A `SimRollout` behind the HAL protocol: one `send_action` = one control step of the scene."""

    def __init__(
        self,
        robot: RobotManifest,
        scene: SimRollout,
        state_names: list[str],
        action_names: list[str],
        task: str | None = None,
    ):
        super().__init__(robot)
        self.scene = scene
        self._state_names = state_names
        self._action_names = action_names
        self._task = task
        self._obs: Observation | None = None
        self._stamp = 0.0
        self.reward = 0.0
        self.success = False
        self.terminated = False
        for name, shape in scene.spec.cameras.items():
            self.cameras[name] = PolledCamera(name, shape, self._imager(name))

    @property
    def state_dim(self) -> int:
        return len(self._state_names)

    @property
    def action_dim(self) -> int:
        return len(self._action_names)

    @property
    def state_names(self) -> list[str]:
        return self._state_names

    @property
    def action_names(self) -> list[str]:
        return self._action_names

    @property
    def task(self) -> str | None:
        return self._task

    @property
    def has_reward(self) -> bool:
        return True

    def close(self) -> None:
        try:
            super().close()
        finally:
            self.scene.close()

    def _connect(self) -> None:
        pass

    def _disconnect(self) -> None:
        pass

    def begin_episode(self, seed: int) -> dict[str, Any]:
        self._obs = self.scene.reset(seed)
        self._stamp = monotonic()
        self.reward, self.success, self.terminated = 0.0, False, False
        return self.scene.initial_state()

    def _current(self) -> Observation:
        if self._obs is None:
            raise ConfigError("scene HAL: begin_episode() was not called")
        return self._obs

    def _imager(self, name: str) -> Callable[[], Image]:
        return lambda: self._image(name)

    def _image(self, name: str) -> Image:
        return self._current().images[name]

    def privileged(self) -> Privileged:
        return self._current().privileged

    @property
    def environment_state_names(self) -> tuple[str, ...]:
        return self.scene.spec.environment_state_names  # the names `record --scene` gives the same scene

    def environment_state(self) -> F32 | None:
        """The scene's own `observation.environment_state` (its object poses), when it declares one."""
        env = self._current().environment_state
        return None if env is None or not self.environment_state_names else np.asarray(env, dtype=np.float32)

    def _read_state(self) -> RobotState:
        return RobotState(np.asarray(self._current().state, dtype=np.float32), monotonic())

    def _send(self, command: JointCommand) -> JointCommand:
        result = self.scene.step(command.positions)
        self._obs = result.observation
        self._stamp = monotonic()
        self.reward, self.success, self.terminated = result.reward, result.success, result.terminated
        return command

    def _hold(self) -> None:
        pass  # a paused simulation does not move

    def outcome(self) -> Outcome | None:
        return Outcome(self.reward, self.success, self.terminated)
