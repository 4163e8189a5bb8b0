"""Registries: SCENES (scene types -> producer factories), POLICIES (policy ids -> adapters), ROBOTS
(auto-discovered from `robots/<id>/robot.yaml`), plus resolution of scene and rSkill references."""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping
from pathlib import Path
from typing import Literal

from openral_data import paths
from openral_data.errors import ConfigError, OpenralError, UsageError
from openral_data.policies.base import PolicyAdapter
from openral_data.policies.basic import RandomPolicy, ZeroPolicy
from openral_data.schemas.base import load_model
from openral_data.schemas.robot import RobotManifest
from openral_data.schemas.rskill import RSkillManifest
from openral_data.schemas.scene import SimScene
from openral_data.types import SimRollout

SceneFactory = Callable[[SimScene, RobotManifest, RSkillManifest, str], SimRollout]
PolicyFactory = Callable[[RSkillManifest], PolicyAdapter]


def _mock_factory(scene: SimScene, robot: RobotManifest, rskill: RSkillManifest, source: str) -> SimRollout:
    from openral_data.producers.sim.mock import MockScene

    return MockScene(scene, state_dim=rskill.state_contract.dim, source=source)


def _tabletop_factory(task: Literal["push", "pick_place"]) -> SceneFactory:
    def make(scene: SimScene, robot: RobotManifest, rskill: RSkillManifest, source: str) -> SimRollout:
        from openral_data.producers.sim.mujoco.scene import TabletopScene

        return TabletopScene(scene, robot, rskill, task, source=source, rskill_source=f"rskill {rskill.id}")

    return make


def _pusht_factory(scene: SimScene, robot: RobotManifest, rskill: RSkillManifest, source: str) -> SimRollout:
    from openral_data.producers.sim.pusht import PushTScene

    return PushTScene(scene, rskill, source=source, rskill_source=f"rskill {rskill.id}")


def _aloha_factory(scene: SimScene, robot: RobotManifest, rskill: RSkillManifest, source: str) -> SimRollout:
    from openral_data.producers.sim.aloha import AlohaScene

    return AlohaScene(scene, rskill, source=source, rskill_source=f"rskill {rskill.id}")


def _libero_factory(scene: SimScene, robot: RobotManifest, rskill: RSkillManifest, source: str) -> SimRollout:
    from openral_data.producers.sim.libero.scene import LiberoScene

    return LiberoScene(scene, rskill, source=source, rskill_source=f"rskill {rskill.id}")


def _suite_factory(kind: Literal["robosuite", "metaworld"]) -> SceneFactory:
    """Benchmark-suite simulators (issue 7): imported only when a scene of theirs is built."""

    def make(scene: SimScene, robot: RobotManifest, rskill: RSkillManifest, source: str) -> SimRollout:
        rskill_source = f"rskill {rskill.id}"
        if kind == "robosuite":
            from openral_data.producers.sim.robosuite import RobosuiteScene

            return RobosuiteScene(scene, robot, rskill, source, rskill_source)
        from openral_data.producers.sim.metaworld import MetaWorldScene

        return MetaWorldScene(scene, robot, rskill, source, rskill_source)

    return make


def _metaworld_expert(rskill: RSkillManifest) -> PolicyAdapter:
    from openral_data.policies.metaworld_expert import MetaWorldExpert

    return MetaWorldExpert(rskill)


def _scripted(name: str) -> PolicyFactory:
    def make(rskill: RSkillManifest) -> PolicyAdapter:
        from openral_data.policies import scripted

        cls: type[scripted.ScriptedPush] | type[scripted.ScriptedPickPlace] = getattr(scripted, name)
        return cls(rskill)

    return make


def _lerobot(rskill: RSkillManifest) -> PolicyAdapter:
    from openral_data.policies.lerobot_policy import make_lerobot_policy

    return make_lerobot_policy(rskill)


def _sweep(rskill: RSkillManifest) -> PolicyAdapter:
    from openral_data.policies.sweep import SweepPolicy

    return SweepPolicy(rskill)


SCENES: dict[str, SceneFactory] = {
    "mock": _mock_factory,
    "tabletop_push": _tabletop_factory("push"),
    "tabletop_pick_place": _tabletop_factory("pick_place"),
    "gym_pusht": _pusht_factory,
    "gym_aloha": _aloha_factory,
    "libero": _libero_factory,
    "robosuite": _suite_factory("robosuite"),
    "metaworld": _suite_factory("metaworld"),
}
POLICIES: dict[str, PolicyFactory] = {
    "zero": ZeroPolicy,
    "random": RandomPolicy,
    "scripted_push": _scripted("ScriptedPush"),
    "scripted_pick_place": _scripted("ScriptedPickPlace"),
    "metaworld_expert": _metaworld_expert,
    "lerobot": _lerobot,
    "sweep": _sweep,
}


def unknown(kind: str, value: str, valid: list[str]) -> OpenralError:
    return UsageError(f"unknown {kind} {value!r}; valid: {', '.join(sorted(valid)) or '(none)'}")


def scene_factory(scene_type: str, source: str) -> SceneFactory:
    if scene_type not in SCENES:
        raise ConfigError(
            f"{source}: scene.type: unknown scene type {scene_type!r}; valid: {', '.join(sorted(SCENES))}"
        )
    return SCENES[scene_type]


def policy_factory(rskill: RSkillManifest, source: str) -> PolicyFactory:
    if rskill.policy not in POLICIES:
        raise ConfigError(f"{source}: policy: unknown policy {rskill.policy!r}; valid: {', '.join(sorted(POLICIES))}")
    return POLICIES[rskill.policy]


# --- robots -----------------------------------------------------------------------------------------------


def robot_ids() -> list[str]:
    root = paths.robots_dir()
    return sorted(p.parent.name for p in root.glob("*/robot.yaml")) if root.is_dir() else []


class RobotRegistry(Mapping[str, RobotManifest]):
    """ROBOTS: every `robots/<id>/robot.yaml`, discovered on each access (adding a folder adds a robot).

    Looking up an unknown id raises an OpenralError that lists the valid ones.
    """

    def __getitem__(self, robot_id: str) -> RobotManifest:
        return load_robot(robot_id)

    def __contains__(self, robot_id: object) -> bool:
        return isinstance(robot_id, str) and robot_id in robot_ids()

    def __iter__(self) -> Iterator[str]:
        return iter(robot_ids())

    def __len__(self) -> int:
        return len(robot_ids())


def load_robot(robot_id: str) -> RobotManifest:
    path = paths.robots_dir() / robot_id / "robot.yaml"
    if not path.exists():  # a folder or a broken file in its place is reported by the loader, naming it
        raise unknown("robot", robot_id, robot_ids())
    robot = load_model(RobotManifest, path)
    if robot.name != robot_id:
        raise ConfigError(f"{path}: name: {robot.name!r} must equal its folder name {robot_id!r}")
    return robot


ROBOTS = RobotRegistry()


# --- rSkills ----------------------------------------------------------------------------------------------


def rskill_ids() -> list[str]:
    root = paths.rskills_dir()
    return sorted(p.parent.name for p in root.glob("*/rskill.yaml")) if root.is_dir() else []


def resolve_rskill(ref: str) -> tuple[RSkillManifest, Path]:
    """An rSkill id (folder under `rskills/`), a folder holding `rskill.yaml`, or a YAML file."""
    candidate = Path(ref).expanduser()
    if candidate.is_dir():
        candidate = candidate / "rskill.yaml"
    if not candidate.is_file():
        by_id = paths.rskills_dir() / ref / "rskill.yaml"
        if not by_id.is_file():
            raise unknown("rSkill", ref, rskill_ids())
        candidate = by_id
    return _anchor_checkpoint(load_model(RSkillManifest, candidate), candidate), candidate


def _anchor_checkpoint(rskill: RSkillManifest, path: Path) -> RSkillManifest:
    """A relative `policy_extras.checkpoint` is relative to the manifest's folder (not the working directory)."""
    value = rskill.policy_extras.get("checkpoint")
    if not isinstance(value, str) or not value or Path(value).expanduser().is_absolute():
        return rskill
    extras = {**rskill.policy_extras, "checkpoint": str((path.parent / value).resolve())}
    return rskill.model_copy(update={"policy_extras": extras})


# --- scenes -----------------------------------------------------------------------------------------------

SCENE_TIERS = ("sim", "benchmark", "deploy")


def scene_files() -> dict[str, Path]:
    out: dict[str, Path] = {}
    for tier in SCENE_TIERS:
        folder = paths.scenes_dir() / tier
        for p in sorted(folder.glob("*.yaml")) if folder.is_dir() else []:
            out.setdefault(p.stem, p)
    return out


def resolve_scene_path(ref: str) -> Path:
    """A path to a scene YAML, or a scene file's stem under `scenes/{sim,benchmark,deploy}/`."""
    candidate = Path(ref).expanduser()
    if candidate.is_file():
        return candidate
    files = scene_files()
    if ref in files:
        return files[ref]
    if candidate.suffix in (".yaml", ".yml") or "/" in ref:
        raise ConfigError(f"{ref}: file not found")
    raise unknown("scene", ref, list(files))
