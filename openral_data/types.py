"""The shared data types and protocols every layer speaks.

Producers emit `Observation`s and `StepResult`s (`SimRollout`, `ProducerSpec`); the dataset bridge turns them into
`Frame`s under a `DatasetSchema`; sinks (`Sink`) take frames and report `EpisodeRecord`s.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Literal, Protocol, TypedDict, runtime_checkable

import numpy as np
import numpy.typing as npt


@dataclass(frozen=True)
class CameraShape:
    height: int
    width: int
    # a depth camera: its frames are (H, W) depth maps, uint16 millimetres ("mm") or float32 metres ("m")
    depth_unit: Literal["mm", "m"] | None = None
    # extra entries of the camera feature's `info` (e.g. `camera_info`: intrinsics from a CameraInfo topic)
    info: dict[str, Any] = field(default_factory=dict, compare=False, hash=False)
    # a segmentation mask: its frames are (H, W) uint16 object ids (0 = background; the names in
    # `info["segmentation_ids"]`, {"<id>": name})
    segmentation: bool = False


@dataclass(frozen=True)
class ProducerSpec:
    """What a producer emits and accepts. `None` dims mean "any" (the mock accepts any action size)."""

    state_dim: int | None
    action_dim: int | None
    cameras: dict[str, CameraShape]
    fps: int
    can_restore_state: bool = False
    # per-dimension names of `Observation.environment_state` (lerobot's `observation.environment_state`) when the
    # producer fills it; empty: its observations carry none
    environment_state_names: tuple[str, ...] = ()


class Privileged(TypedDict, total=False):
    """`Observation.privileged`: simulator ground truth, never recorded. Each scene fills the keys it knows.

    Replay and `observation.environment_state` read `object_poses` (object name -> [x, y, z, qw, qx, qy, qz],
    world frame) from any scene; the MuJoCo tabletop experts read `ee_pos`, `ee_quat`, `table_height`, `objects`
    (name -> pos, size, ...) and `roles` (role -> object); `metaworld-expert` reads `suite`, `task` and
    `metaworld_obs`. The rest is what each scene offers its own experts and tests (robosuite also passes its
    environment's own observation keys, undeclared here)."""

    object_poses: dict[str, Any]
    fixed_poses: dict[str, Any]  # the same of fixed objects (a goal drawn from the seed)
    # MuJoCo tabletop scenes (producers/sim/mujoco/scene.py)
    ee_pos: npt.NDArray[np.float64]
    ee_quat: npt.NDArray[np.float64]
    gripper: float
    table_height: float
    task: str  # the scene's task kind (tabletop); the MetaWorld task name (metaworld)
    objects: dict[str, dict[str, Any]]
    roles: dict[str, str]
    success: dict[str, Any] | None
    success_terms: list[tuple[str, bool]]  # the criterion's leaves and whether each holds now (teleop status)
    workspace: dict[str, tuple[float, float]]
    cube_pos: npt.NDArray[np.float64]  # the `object` role's pose and size, the `goal` role's place (push, pick)
    cube_quat: npt.NDArray[np.float64]
    cube_size: float
    goal_pos: npt.NDArray[np.float64]
    goal_radius: float
    # robosuite
    eef_pos: npt.NDArray[np.float64]
    env: str
    suite: str  # "robosuite" | "metaworld"
    # MetaWorld
    metaworld_obs: npt.NDArray[np.float64]
    # LIBERO
    joint_pos: npt.NDArray[np.float64]
    eef_quat_xyzw: npt.NDArray[np.float64]
    object_state: npt.NDArray[np.float64]
    # PushT
    agent_pos: npt.NDArray[np.float64]
    block_pos: npt.NDArray[np.float64]
    block_angle: float
    goal_pose: npt.NDArray[np.float64]
    coverage: float
    # ALOHA
    reward_stage: int
    qvel: npt.NDArray[np.float64]
    # ManiSkill3 (suite "maniskill", task = its env id): the seed of the episode's reset, which its expert replans
    maniskill_seed: int


@dataclass
class Observation:
    """What the policy sees at one step: camera images (HWC uint8; a depth camera's (H, W) float32 metres or
    uint16 millimetres, a segmentation mask's (H, W) uint16 ids, per its CameraShape), the state vector and the
    task text.

    `time` is the producer's clock for this observation in seconds since the episode began: simulation time
    for sim scenes, a monotonic clock for hardware. `None` means "no clock of its own" (frame index / fps).

    `privileged` is simulator ground truth (object poses, ...) that scripted experts may read; it is never
    recorded, and a learned policy must not rely on it.

    `environment_state` is lerobot's `observation.environment_state` (non-robot state the policy may see, e.g.
    object poses): required exactly when the dataset schema names one (`DatasetSchema.environment_state_names`).
    """

    images: dict[str, npt.NDArray[Any]]
    state: npt.NDArray[Any]
    task: str
    time: float | None = None
    privileged: Privileged = field(default_factory=Privileged)
    environment_state: npt.NDArray[Any] | None = None
    # world poses [x, y, z, qw, qx, qy, qz] of the frames cameras are mounted on (a wrist camera's body, named as
    # its extrinsics' `parent_frame`) at this step: MCAP publishes them on /tf so the camera can be placed
    transforms: dict[str, npt.NDArray[np.float64]] = field(default_factory=dict)


@dataclass
class StepResult:
    observation: Observation
    reward: float
    success: bool
    terminated: bool
    info: dict[str, Any] = field(default_factory=dict)


@runtime_checkable
class SimRollout(Protocol):
    """A simulated scene. `reset(seed)` starts an episode; `step(action)` advances it by one control step.

    Replay reads simulator ground truth from `Observation.privileged["object_poses"]` when a scene provides it:
    a dict of object name -> [x, y, z, qw, qx, qy, qz] (world frame), compared with the recorded initial
    state's `object_poses` of the same form.

    Arrays returned in observations belong to the caller (a producer must not write into them later).
    """

    spec: ProducerSpec

    def reset(self, seed: int) -> Observation: ...

    def step(self, action: npt.NDArray[np.float32]) -> StepResult: ...

    def render(self) -> dict[str, npt.NDArray[Any]]:
        """The current frame of every camera in `spec.cameras` (uint8 HWC; a depth camera's as its CameraShape)."""
        ...

    def initial_state(self) -> dict[str, Any]:
        """JSON-serialisable data that restores the state `reset` produced (for replay)."""
        ...

    def reset_to(self, initial_state: dict[str, Any]) -> Observation:
        """Start an episode from exactly the state `initial_state()` described when it was recorded (replay).

        Valid only when `spec.can_restore_state`; a scene that cannot restore a state keeps it False and raises
        an OpenralError here. From the restored state, the same actions must give the same rollout.
        """
        ...

    def close(self) -> None: ...


@dataclass(frozen=True)
class FrameColumn:
    """A per-frame feature beyond the scalar `frame_extras`: a float32 vector with one name per dimension
    (e.g. `openral.policy_action`, the action's names) or a bool flag (`names` empty: shape [1])."""

    key: str
    dtype: Literal["float32", "bool"]
    names: tuple[str, ...] = ()

    @property
    def dim(self) -> int:
        return len(self.names) if self.dtype == "float32" else 1


@dataclass(frozen=True)
class DatasetSchema:
    """Everything a sink needs to lay out a dataset before the first frame arrives."""

    fps: int
    state_names: tuple[str, ...]
    action_names: tuple[str, ...]
    cameras: dict[str, CameraShape]
    robot_type: str | None  # None: not known (lerobot writes null, and an edit keeps it)
    metadata: dict[str, Any] = field(
        default_factory=dict
    )  # where frames came from: formats.lerobot_v3.provenance.Origin
    # Which outcomes the source knows. A sink stores no reward / success it was not given (a converted hardware
    # log has none): the frames' `reward` / `success` values are then ignored and episode success is unknown.
    has_reward: bool = True
    has_success: bool = True
    # Extra per-frame float columns (e.g. a HAL's real monotonic timestamps, overrun and safety flags); every
    # frame must carry exactly these keys in `Frame.extras`. LeRobot v3: float32 features of shape [1].
    frame_extras: tuple[str, ...] = ()
    # Extra per-frame vector/flag features (`Frame.columns`, the same keys on every frame); none by default
    frame_columns: tuple[FrameColumn, ...] = ()
    # lerobot's `observation.environment_state` (e.g. object poses), per-dimension names; empty: the source has none
    environment_state_names: tuple[str, ...] = ()

    @property
    def state_dim(self) -> int:
        return len(self.state_names)

    @property
    def action_dim(self) -> int:
        return len(self.action_names)


@dataclass
class Frame:
    """Row t: the observation the policy saw at step t, the action it produced, and what followed."""

    state: npt.NDArray[np.float32]
    action: npt.NDArray[np.float32]
    images: dict[str, npt.NDArray[Any]]  # uint8 (H, W, 3); a depth camera's (H, W) uint16 mm / float32 m
    task: str
    reward: float
    done: bool
    success: bool
    timestamp: float = 0.0  # seconds since the episode began, from the producer's clock (see Observation.time)
    extras: dict[str, float] = field(default_factory=dict)  # DatasetSchema.frame_extras values
    environment_state: npt.NDArray[np.float32] | None = None  # when DatasetSchema.environment_state_names is set
    transforms: dict[str, npt.NDArray[np.float64]] = field(default_factory=dict)  # see Observation.transforms
    columns: dict[str, npt.NDArray[Any]] = field(default_factory=dict)  # DatasetSchema.frame_columns values


@dataclass(frozen=True)
class EpisodeStart:
    seed: int | None  # None: not known (an edited episode of a dataset that did not record its seed)
    initial_state: dict[str, Any]


@dataclass(frozen=True)
class EpisodeRecord:
    """What a sink reports for a finished episode: durable when `end_episode` returns, or for a sink that commits
    behind the recording (`CommitsBehind`) once its `close()` returned."""

    index: int
    length: int
    success: bool | None  # None: unknown (the source says nothing about success)
    seed: int | None  # None: unknown (see EpisodeStart)


class Sink(Protocol):
    def begin_episode(self, start: EpisodeStart) -> None: ...

    def add_frame(self, frame: Frame) -> None: ...

    def annotate_episode(self, info: dict[str, Any]) -> None:
        """Keep `info` (JSON-able) with the open episode (before `end_episode`); a no-op in a sink that stores no
        episode annotations."""

    def end_episode(self, success: bool | None) -> EpisodeRecord: ...

    def discard_episode(self) -> None: ...

    def close(self) -> None: ...


@runtime_checkable
class CommitsBehind(Protocol):
    """A sink whose `end_episode` may return before the episode is committed (its commits run behind the recording,
    in order); a commit that fails is raised by a later `end_episode`, `begin_episode` or `close`."""

    @property
    def uncommitted(self) -> int:
        """The episodes whose `end_episode` returned and whose commit has not completed (yet, or it failed)."""
        ...


class FrameObserver(Protocol):
    """Watches a recording without being part of it (a debug video, a live view): it is shown every validated
    frame after the sinks took it, with the episode's number; it never changes what is recorded. `end_episode`
    gets the committed episode's record, or None when the episode was discarded (Ctrl-C, a contract violation).
    An observer that cannot keep up drops what it shows, never holds a frame back."""

    def begin_episode(self, index: int, start: EpisodeStart) -> None: ...

    def add_frame(self, frame: Frame) -> None: ...

    def end_episode(self, record: EpisodeRecord | None) -> None: ...

    def close(self) -> None: ...


@runtime_checkable
class Previews(Protocol):
    """An observer that also shows where an episode starts before it records (the live view: a person waiting to
    press space sees the scene): the cameras' pictures after the reset."""

    def preview(self, index: int, images: dict[str, npt.NDArray[Any]]) -> None: ...
