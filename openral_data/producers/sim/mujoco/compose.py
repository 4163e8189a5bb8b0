"""Compose a tabletop world with `mujoco.MjSpec` from a robot manifest and a scene: no per-robot code.

World frame: floor at z = 0, table top at `table_height`, robot base on the table (manifest `base_pos`
unless the scene sets one). The arm is loaded from `assets.mjcf` under the prefix `robot/`, the gripper from
`assets.gripper_mjcf` under `robot/gripper/` at the manifest's `attach_body`; an arm MJCF with an integrated
gripper (no `assets.gripper_mjcf`, e.g. the SO-100/SO-101 jaw) names its gripper joints, actuators and grasp
site under `robot/`.

Control (documented choice): the robot MJCF's torque motors on the arm joints are turned into position
servos (gain kp, damping kv from the manifest, force limited to the motor's original torque range; an MJCF
that already drives a joint with a position servo keeps that servo's force range) and the
arm's bodies get gravity compensation (`gravcomp`), so a joint-position target is held without sag and the
whole control law runs inside MuJoCo's step (implicitfast integrator), never in Python per sub-step.

The table, its light and the scene's objects are objects.py's; their placement per episode is placement.py's.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np
import numpy.typing as npt

from openral_data.errors import ConfigError
from openral_data.producers.sim.mujoco.objects import add_objects, add_table, add_textures
from openral_data.schemas.mujoco import MujocoRobotWiring, TabletopParams
from openral_data.schemas.scene import SceneCamera
from openral_data.schemas.tabletop import TabletopObject

ROBOT = "robot/"
GRIPPER = "robot/gripper/"


@dataclass(frozen=True)
class Composed:
    model: mujoco.MjModel
    arm_joints: list[str]  # full (prefixed) joint names, action/state order
    gripper_actuators: list[str]
    gripper_joints: list[str]
    ee_site: str
    cameras: list[str]  # camera names in the compiled model, same order as the scene's cameras


def look_at_quat(pos: npt.ArrayLike, target: npt.ArrayLike) -> npt.NDArray[np.float64]:
    """Quaternion of a MuJoCo camera at `pos` looking at `target` (camera looks along its -z, y is up)."""
    p, t = np.asarray(pos, dtype=np.float64), np.asarray(target, dtype=np.float64)
    forward = t - p
    norm = float(np.linalg.norm(forward))
    if norm < 1e-9:
        raise ValueError("camera pos and lookat coincide")
    forward /= norm
    up = np.array([0.0, 0.0, 1.0])
    if abs(float(forward @ up)) > 0.999:  # looking straight down/up: image up is world +x
        up = np.array([1.0, 0.0, 0.0])
    x = np.cross(forward, up)
    x /= np.linalg.norm(x)
    y = np.cross(-forward, x)
    mat = np.stack([x, y, -forward], axis=1)  # columns: camera axes in world frame
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, mat.reshape(-1))
    return quat


def _sanitize(spec: mujoco.MjSpec) -> None:
    """Make packaged MJCFs attachable and compilable without editing them.

    * a second mesh of an already declared name is dropped (robosuite's Robotiq 2F-85 declares one twice, the
      second naming a file the wheel does not ship; geoms resolve names to the first);
    * meshes only visual geoms use get shell inertia (a thin visual shell has no volume; bodies carry explicit
      inertials, so this changes no dynamics);
    * a mesh declared without a name gets the one MuJoCo would give it (its file's stem), so attaching under a
      prefix renames it along with the geoms that use it (the SO-101 MJCF declares its meshes so).
    """
    for mesh in spec.meshes:
        if not mesh.name and mesh.file:
            mesh.name = Path(mesh.file).stem
    seen: set[str] = set()
    for mesh in list(spec.meshes):
        if mesh.name in seen:
            mesh.delete()
        seen.add(mesh.name)
    collision = {g.meshname for g in spec.geoms if g.contype != 0 or g.conaffinity != 0}
    for mesh in spec.meshes:
        if mesh.name not in collision:
            mesh.inertia = mujoco.mjtMeshInertia.mjMESH_INERTIA_SHELL


def _servo_arm(spec: mujoco.MjSpec, wiring: MujocoRobotWiring, source: str) -> list[str]:
    joints = [ROBOT + j for j in wiring.arm_joints]
    motors: dict[str, mujoco.MjsActuator] = {}
    for act in spec.actuators:
        if act.target in joints:
            motors[act.target] = act
    for k, name in enumerate(joints):
        joint = spec.joint(name)
        if joint is None:
            raise ConfigError(f"{source}: sim.arm_joints[{k}]: no joint {wiring.arm_joints[k]!r} in the robot MJCF")
        joint.armature = max(joint.armature, wiring.armature)
        act = motors.get(name)
        if act is None:
            act = spec.add_actuator(name=f"{name}_servo", target=name, trntype=mujoco.mjtTrn.mjTRN_JOINT)
        elif act.ctrllimited == mujoco.mjtLimited.mjLIMITED_TRUE and act.biastype == mujoco.mjtBias.mjBIAS_NONE:
            # a torque motor: its control range is a torque range (a position servo's is a joint range)
            act.forcerange = np.array(act.ctrlrange, dtype=np.float64)
            act.forcelimited = mujoco.mjtLimited.mjLIMITED_TRUE
        kp, kv = wiring.kp[k], wiring.kv[k]
        act.gaintype = mujoco.mjtGain.mjGAIN_FIXED
        act.gainprm = np.array([kp] + [0.0] * 9)
        act.biastype = mujoco.mjtBias.mjBIAS_AFFINE
        act.biasprm = np.array([0.0, -kp, -kv] + [0.0] * 7)
        act.gear = np.array([1.0, 0, 0, 0, 0, 0])
        if joint.limited == mujoco.mjtLimited.mjLIMITED_TRUE or (
            joint.limited == mujoco.mjtLimited.mjLIMITED_AUTO and joint.range[0] < joint.range[1]
        ):
            act.ctrlrange = np.array(joint.range, dtype=np.float64)
            act.ctrllimited = mujoco.mjtLimited.mjLIMITED_TRUE
        else:
            act.ctrllimited = mujoco.mjtLimited.mjLIMITED_FALSE
    return joints


def _attach_gripper(robot: mujoco.MjSpec, gripper_mjcf: Path | None, wiring: MujocoRobotWiring, source: str) -> str:
    """Attach the gripper MJCF at `sim.attach_body`; the prefix its names get in the world (`robot/` alone for
    an arm MJCF with an integrated gripper)."""
    if gripper_mjcf is None:
        return ROBOT
    if wiring.attach_body is None:
        raise ConfigError(f"{source}: sim.attach_body: needed to attach assets.gripper_mjcf")
    gripper = mujoco.MjSpec.from_file(str(gripper_mjcf))
    _sanitize(gripper)
    attach = robot.body(wiring.attach_body)
    if attach is None:
        raise ConfigError(f"{source}: sim.attach_body: no body {wiring.attach_body!r} in the robot MJCF")
    grip_root = gripper.worldbody.first_body()
    if grip_root is None:
        raise ConfigError(f"{source}: assets.gripper_mjcf: the gripper MJCF has no body")
    attach.add_frame().attach_body(grip_root, "gripper/", "")
    return GRIPPER


def compose(
    *,
    robot_mjcf: Path,
    gripper_mjcf: Path | None,
    wiring: MujocoRobotWiring,
    params: TabletopParams,
    cameras: list[SceneCamera],
    robot_source: str,
    scene_source: str,
    objects: Sequence[TabletopObject] = (),
    textures: bool = False,
) -> Composed:
    """Build and compile the world with `objects` on the table (none: an empty table) and, with `textures`, the
    shipped textures as materials (`randomize.textures`); ConfigError (naming the manifest or scene field) on bad
    wiring."""
    world = _world(params, cameras)
    grip_prefix = _place_robot(world, robot_mjcf, gripper_mjcf, wiring, params, robot_source)
    for body in world.bodies:
        if body.name.startswith(ROBOT):
            body.gravcomp = 1.0
    arm_joints = _servo_arm(world, wiring, robot_source)
    _check_gripper(world, wiring, grip_prefix, gripper_mjcf is not None, robot_source)

    # --- the table, the objects, lights (objects.py) ----------------------------------------------------------
    add_table(world, params.table_height, params.table_size, params.table_center)
    add_objects(world, objects, f"{scene_source}: scene.params.objects")
    if textures:
        add_textures(world)

    cam_names = _add_cameras(world, cameras, wiring, robot_source, scene_source)
    try:
        model = world.compile()
    except ValueError as exc:
        raise ConfigError(f"{robot_source}: the composed MuJoCo model does not compile: {exc}") from None
    g = wiring.gripper
    return Composed(
        model=model,
        arm_joints=arm_joints,
        gripper_actuators=[grip_prefix + a for a in g.actuators],
        gripper_joints=[grip_prefix + j for j in g.joints],
        ee_site=grip_prefix + g.ee_site,
        cameras=cam_names,
    )


def _world(params: TabletopParams, cameras: list[SceneCamera]) -> mujoco.MjSpec:
    """The empty world: physics options, headlight, an offscreen buffer as large as the largest camera."""
    world = mujoco.MjSpec()
    world.modelname = "openral_tabletop"
    world.compiler.degree = False  # robot MJCFs declare radians; attaching keeps the host compiler settings
    world.option.timestep = params.timestep
    world.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    world.option.cone = mujoco.mjtCone.mjCONE_ELLIPTIC
    world.option.impratio = 10.0
    world.visual.headlight.ambient = [0.3, 0.3, 0.3]
    world.visual.headlight.diffuse = [0.3, 0.3, 0.3]
    world.visual.headlight.specular = [0.0, 0.0, 0.0]
    world.visual.global_.offwidth = max([640, *(c.width for c in cameras)])
    world.visual.global_.offheight = max([480, *(c.height for c in cameras)])
    return world


def _place_robot(
    world: mujoco.MjSpec,
    robot_mjcf: Path,
    gripper_mjcf: Path | None,
    wiring: MujocoRobotWiring,
    params: TabletopParams,
    source: str,
) -> str:
    """Load the arm (its gripper attached) and attach it under `robot/` at its base on the table; the prefix the
    gripper's names get (`_attach_gripper`)."""
    robot = mujoco.MjSpec.from_file(str(robot_mjcf))
    _sanitize(robot)
    grip_prefix = _attach_gripper(robot, gripper_mjcf, wiring, source)
    root = robot.body(wiring.root_body)
    if root is None:
        raise ConfigError(f"{source}: sim.root_body: no body {wiring.root_body!r} in the robot MJCF")

    h = params.table_height
    base = (
        params.base_pos
        if params.base_pos is not None
        else (
            wiring.base_pos[0],
            wiring.base_pos[1],
            wiring.base_pos[2] + h,
        )
    )
    yaw = params.base_yaw
    frame = world.worldbody.add_frame(pos=list(base), quat=[np.cos(yaw / 2), 0.0, 0.0, np.sin(yaw / 2)])
    frame.attach_body(root, ROBOT, "")
    return grip_prefix


def _check_gripper(
    world: mujoco.MjSpec, wiring: MujocoRobotWiring, grip_prefix: str, separate: bool, source: str
) -> None:
    """Every gripper actuator, joint and the ee site named by `sim.gripper` exists in the world (`separate`: the
    gripper came from its own MJCF)."""
    g = wiring.gripper
    where = "the gripper MJCF" if separate else "the robot MJCF"
    for field, names in (("actuators", g.actuators), ("joints", g.joints)):
        for k, name in enumerate(names):
            found = world.actuator(grip_prefix + name) if field == "actuators" else world.joint(grip_prefix + name)
            if found is None:
                raise ConfigError(f"{source}: sim.gripper.{field}[{k}]: no {name!r} in {where}")
    if world.site(grip_prefix + g.ee_site) is None:
        raise ConfigError(f"{source}: sim.gripper.ee_site: no site {g.ee_site!r} in {where}")


def _add_cameras(
    world: mujoco.MjSpec,
    cameras: list[SceneCamera],
    wiring: MujocoRobotWiring,
    robot_source: str,
    scene_source: str,
) -> list[str]:
    """The scene's cameras, on the wrist mount or in the world looking at their target; their names in order."""
    cam_names: list[str] = []
    for k, cam in enumerate(cameras):
        if cam.mount == "wrist":
            wc = wiring.wrist_camera
            if wc is None:
                raise ConfigError(
                    f"{scene_source}: scene.cameras[{k}].mount: robot has no wrist camera mount (sim.wrist_camera)"
                )
            body = world.body(ROBOT + wc.body)
            if body is None:
                raise ConfigError(f"{robot_source}: sim.wrist_camera.body: no body {wc.body!r}")
            body.add_camera(name=cam.name, pos=list(wc.pos), quat=list(wc.quat), fovy=wc.fovy)
        else:
            if cam.pos is None or cam.lookat is None:
                raise ConfigError(f"{scene_source}: scene.cameras[{k}]: a world camera needs pos and lookat")
            try:
                quat = look_at_quat(cam.pos, cam.lookat)
            except ValueError as exc:
                raise ConfigError(f"{scene_source}: scene.cameras[{k}]: {exc}") from None
            world.worldbody.add_camera(name=cam.name, pos=list(cam.pos), quat=list(quat), fovy=cam.fovy)
        cam_names.append(cam.name)
    return cam_names
