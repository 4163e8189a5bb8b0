"""Scene tiers. DeployScene (where: scene) ⊆ SimScene (+ task, seed, n_episodes) ⊆ BenchmarkScene (+ metadata).

Each tier has its own strict loader. A scene never binds a policy: it may suggest the rSkill `record` uses when
no `--rskill` is given (`scene.default_rskill`), and `--rskill` always wins.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Literal

from pydantic import Field, model_validator

from openral_data.errors import ConfigError
from openral_data.schemas.base import StrictModel, read_yaml, validate

Tier = Literal["deploy", "sim", "benchmark"]
# the largest camera side we render or record: checked when the file is loaded, before any frame is allocated
MAX_CAMERA_SIDE = 4096
MAX_FRAME_PIXELS = 4 * MAX_CAMERA_SIDE**2  # all cameras of one step together (~200 MB of RGB)
# episode k of a recording uses seed + k; every simulator we drive takes a uint32 seed (numpy's legacy seeding)
MAX_SEED = 2**32 - 1
MAX_STEPS = 10**7  # steps per episode (over a day of recording at 100 fps); `1e30` is a typo, not a limit
_POLICY_KEYS = ("vla", "policy", "rskill")


class SceneCamera(StrictModel):
    """A camera the scene renders. Physics scenes place it: `mount: world` at `pos` looking at `lookat`
    (metres, world frame), `mount: wrist` where the robot manifest's wrist camera is."""

    name: str = Field(min_length=1, pattern=r"^[A-Za-z0-9_]+$")
    width: int = Field(gt=0, le=MAX_CAMERA_SIDE)
    height: int = Field(gt=0, le=MAX_CAMERA_SIDE)
    mount: Literal["world", "wrist"] = "world"
    pos: tuple[float, float, float] | None = None
    lookat: tuple[float, float, float] | None = None
    fovy: float = Field(default=45.0, gt=0, lt=180)
    depth: bool = Field(
        default=False,
        description="also record this camera's depth (metres, float32) as the depth camera `<name>_depth` "
        "(scenes whose producer renders depth: the MuJoCo scenes)",
    )
    segmentation: bool = Field(
        default=False,
        description="also record this camera's segmentation mask (uint16 object ids per pixel, 0 = background) "
        "as `<name>_segmentation` (the MuJoCo scenes)",
    )


def depth_camera_name(camera: str) -> str:
    """The name of camera `camera`'s depth stream (`front` -> `front_depth`, `observation.images.front_depth`)."""
    return f"{camera}_depth"


def segmentation_camera_name(camera: str) -> str:
    """The name of camera `camera`'s segmentation stream (`front` -> `front_segmentation`)."""
    return f"{camera}_segmentation"


def stream_names(camera: SceneCamera) -> list[str]:
    """Every stream a scene camera records: its colour frames, then its depth and segmentation if asked."""
    return (
        [camera.name]
        + ([depth_camera_name(camera.name)] if camera.depth else [])
        + ([segmentation_camera_name(camera.name)] if camera.segmentation else [])
    )


class ObservationsConfig(StrictModel):
    """What a scene's observations carry besides the robot state and the camera frames."""

    environment_state: bool = Field(
        default=False,
        description="record `observation.environment_state`: every movable object's pose per frame "
        "(`<object>.x, .y, .z, .qw, .qx, .qy, .qz`, world frame; scenes that report object poses)",
    )
    environment_goal: bool = Field(
        default=False,
        description="with `environment_state`, also the pose of the task's fixed goal (the `goal` role, drawn "
        "from the seed), after the movable objects': what a state-only policy needs to know where to push",
    )

    @model_validator(mode="after")
    def _goal_needs_state(self) -> ObservationsConfig:
        if self.environment_goal and not self.environment_state:
            raise ValueError("environment_goal needs environment_state: true")
        return self


class RenderConfig(StrictModel):
    """Offscreen rendering. Shadows, reflections and detailed robot meshes cost most of the CPU render time."""

    shadows: bool = False
    reflections: bool = False
    robot_meshes: Literal["collision", "visual"] = Field(
        default="collision",
        description="draw the robot's collision meshes (coarse, ~6x faster on a CPU) or its detailed visual meshes",
    )


class SceneSpec(StrictModel):
    id: str = Field(min_length=1, pattern=r"^[A-Za-z0-9_\-]+$")
    type: str = Field(min_length=1, description="a SCENES registry key: which producer builds this scene")
    robot: str | None = None
    default_rskill: str | None = Field(
        default=None, min_length=1, description="the rSkill `record` uses when --rskill is not given (an id or path)"
    )
    fixed_robot: bool = Field(
        default=False, description="the scene is defined for `robot` only: `--robot` may not replace it"
    )
    fps: int = Field(default=20, gt=0, le=1000)
    cameras: list[SceneCamera] = Field(default_factory=list)
    render: RenderConfig = Field(default_factory=RenderConfig)
    observations: ObservationsConfig = Field(default_factory=ObservationsConfig)
    params: dict[str, Any] = Field(default_factory=dict)

    @model_validator(mode="after")
    def _unique_cameras(self) -> SceneSpec:
        names = [n for c in self.cameras for n in stream_names(c)]
        dup = sorted({n for n in names if names.count(n) > 1})
        if dup:
            raise ValueError(
                "duplicate camera names (a depth camera is named <camera>_depth, a segmentation mask "
                f"<camera>_segmentation): {dup}"
            )
        pixels = sum(c.width * c.height * len(stream_names(c)) for c in self.cameras)
        if pixels > MAX_FRAME_PIXELS:
            raise ValueError(f"cameras: {pixels} pixels per step in all; at most {MAX_FRAME_PIXELS}")
        return self


class TaskSpec(StrictModel):
    scene_id: str
    instruction: str = Field(min_length=1)
    max_steps: int = Field(default=200, gt=0, le=MAX_STEPS)
    params: dict[str, Any] = Field(default_factory=dict)


class BenchmarkMetadata(StrictModel):
    paper: str = Field(min_length=1)
    honest_scope: str = Field(min_length=1)


class DeployScene(StrictModel):
    tier: Literal["deploy"]
    scene: SceneSpec


class SimScene(StrictModel):
    tier: Literal["sim"]
    scene: SceneSpec
    task: TaskSpec
    seed: int = Field(default=0, ge=0, le=MAX_SEED)
    n_episodes: int = Field(default=1, gt=0)

    @model_validator(mode="after")
    def _task_matches_scene(self) -> SimScene:
        if self.task.scene_id != self.scene.id:
            raise ValueError(f"task.scene_id {self.task.scene_id!r} must equal scene.id {self.scene.id!r}")
        return self


class BenchmarkScene(SimScene):
    tier: Literal["benchmark"]  # type: ignore[assignment]
    seed: int = Field(ge=0, le=MAX_SEED)
    n_episodes: int = Field(gt=0)
    metadata: BenchmarkMetadata


AnyScene = DeployScene | SimScene | BenchmarkScene
_TIERS: dict[str, type[DeployScene] | type[SimScene] | type[BenchmarkScene]] = {
    "deploy": DeployScene,
    "sim": SimScene,
    "benchmark": BenchmarkScene,
}


def _check_raw(data: Any, source: str) -> str:
    if not isinstance(data, dict):
        raise ConfigError(f"{source}: expected a mapping at the top level, got {type(data).__name__}")
    for key in _POLICY_KEYS:
        if key in data:
            raise ConfigError(
                f"{source}: {key}: a scene must not name a policy; the policy comes from --rskill "
                "(a scene may suggest one: scene.default_rskill)"
            )
    tier = data.get("tier")
    if not isinstance(tier, str) or tier not in _TIERS:  # (a list or a mapping is not hashable)
        raise ConfigError(f"{source}: tier: must be one of {sorted(_TIERS)}, got {tier!r}")
    return str(tier)


def load_scene(path: Path) -> AnyScene:
    """Load a scene of whatever tier the file declares, with that tier's strict schema."""
    data = read_yaml(path)
    tier = _check_raw(data, str(path))
    return validate(_TIERS[tier], data, str(path))


def load_recordable_scene(path: Path) -> SimScene:
    """Load a scene `record` can run: SimScene or BenchmarkScene. A DeployScene is refused with the reason."""
    scene = load_scene(path)
    if isinstance(scene, DeployScene):
        raise ConfigError(
            f"{path}: tier: deploy scenes have no task (instruction, success, episode limits), so they cannot "
            "be recorded; use a sim or benchmark scene"
        )
    return scene
