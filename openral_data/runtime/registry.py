"""Registries: SCENES (scene types -> producer factories; a suite's entry, a `SceneType`, also carries the
lister of its tasks), POLICIES (policy ids -> adapters), both open to plug-ins (`@SCENES.register("id")`, entry
points `openral_data.scenes` / `openral_data.policies`); ROBOTS (`robots/<id>/robot.yaml` on the manifest search
path); and resolution of scene and rSkill references."""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping, MutableMapping
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType
from typing import TYPE_CHECKING, Literal, cast

from openral_data import manifests
from openral_data.errors import ConfigError, OpenralError, UsageError
from openral_data.text import choices_hint

if TYPE_CHECKING:  # imported where used: `list` and `doctor` load the registries without numpy or pydantic
    from openral_data.policies.base import PolicyAdapter
    from openral_data.producers.sim.tasks import SuiteTask, TaskLister
    from openral_data.schemas.robot import RobotManifest
    from openral_data.schemas.rskill import RSkillManifest
    from openral_data.schemas.scene import SimScene
    from openral_data.types import SimRollout

SceneFactory = Callable[["SimScene", "RobotManifest", "RSkillManifest", str], "SimRollout"]
PolicyFactory = Callable[["RSkillManifest"], "PolicyAdapter"]


@dataclass(frozen=True)
class SceneType:
    """A scene type registered with its tasks: the producer factory and the lister of the tasks `record --task`
    may choose and `list tasks` prints (`runtime/tasks.py`). Called, it is the factory, so `SCENES` holds it
    like any other; a plain factory registers a scene type without tasks. A plug-in's suite registers one too:
    `SCENES["my_suite"] = SceneType(make_my_suite, tasks=my_suite_tasks)`."""

    make: SceneFactory
    tasks: TaskLister | None = None

    def __call__(self, scene: SimScene, robot: RobotManifest, rskill: RSkillManifest, source: str) -> SimRollout:
        return self.make(scene, robot, rskill, source)


def _mock_factory(scene: SimScene, robot: RobotManifest, rskill: RSkillManifest, source: str) -> SimRollout:
    from openral_data.producers.sim.mock import MockScene

    return MockScene(scene, state_dim=rskill.state_contract.dim, source=source)


def _tabletop_factory(task: str | None) -> SceneFactory:
    """`tabletop` (the task label from `params.task` or the scene id) and the push / pick-place types."""

    def make(scene: SimScene, robot: RobotManifest, rskill: RSkillManifest, source: str) -> SimRollout:
        from openral_data.producers.sim.mujoco.scene import TabletopScene

        return TabletopScene(scene, robot, rskill, task, source=source, rskill_source=f"rskill {rskill.id}")

    return make


def _twin_factory(scene: SimScene, robot: RobotManifest, rskill: RSkillManifest, source: str) -> SimRollout:
    from openral_data.producers.sim.mujoco.twin import TwinScene

    return TwinScene(scene, robot, rskill, source)


def _pusht_factory(scene: SimScene, robot: RobotManifest, rskill: RSkillManifest, source: str) -> SimRollout:
    from openral_data.producers.sim.pusht import PushTScene

    return PushTScene(scene, rskill, source=source, rskill_source=f"rskill {rskill.id}")


def _aloha_factory(scene: SimScene, robot: RobotManifest, rskill: RSkillManifest, source: str) -> SimRollout:
    from openral_data.producers.sim.aloha import AlohaScene

    return AlohaScene(scene, rskill, source=source, rskill_source=f"rskill {rskill.id}")


def _libero_factory(scene: SimScene, robot: RobotManifest, rskill: RSkillManifest, source: str) -> SimRollout:
    from openral_data.producers.sim.libero.scene import LiberoScene

    return LiberoScene(scene, rskill, source=source, rskill_source=f"rskill {rskill.id}")


def _maniskill_factory(scene: SimScene, robot: RobotManifest, rskill: RSkillManifest, source: str) -> SimRollout:
    from openral_data.producers.sim.maniskill.scene import ManiSkillScene

    return ManiSkillScene(scene, rskill, source=source, rskill_source=f"rskill {rskill.id}")


def _maniskill_tasks(scene: SimScene, source: str) -> list[SuiteTask]:
    from openral_data.producers.sim.maniskill import tasks

    return tasks.suite_tasks(scene, source)


def _aloha_tasks(scene: SimScene, source: str) -> list[SuiteTask]:
    from openral_data.producers.sim import aloha

    return aloha.suite_tasks(scene, source)


def _libero_tasks(scene: SimScene, source: str) -> list[SuiteTask]:
    from openral_data.producers.sim.libero import scene as libero

    return libero.suite_tasks(scene, source)


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


def _robosuite_tasks(scene: SimScene, source: str) -> list[SuiteTask]:
    from openral_data.producers.sim import robosuite

    return robosuite.suite_tasks(scene, source)


def _metaworld_tasks(scene: SimScene, source: str) -> list[SuiteTask]:
    from openral_data.producers.sim import metaworld

    return metaworld.suite_tasks(scene, source)


def _zero(rskill: RSkillManifest) -> PolicyAdapter:
    from openral_data.policies.basic import ZeroPolicy

    return ZeroPolicy(rskill)


def _random(rskill: RSkillManifest) -> PolicyAdapter:
    from openral_data.policies.basic import RandomPolicy

    return RandomPolicy(rskill)


def _metaworld_expert(rskill: RSkillManifest) -> PolicyAdapter:
    from openral_data.policies.metaworld_expert import MetaWorldExpert

    return MetaWorldExpert(rskill)


def _maniskill_expert(rskill: RSkillManifest) -> PolicyAdapter:
    from openral_data.policies.maniskill_expert import ManiSkillExpert

    return ManiSkillExpert(rskill)


def _scripted(name: str) -> PolicyFactory:
    def make(rskill: RSkillManifest) -> PolicyAdapter:
        from openral_data.policies import scripted

        cls: PolicyFactory = getattr(scripted, name)
        return cls(rskill)

    return make


def _lerobot(rskill: RSkillManifest) -> PolicyAdapter:
    from openral_data.policies.lerobot_policy import make_lerobot_policy

    return make_lerobot_policy(rskill)


def _mimicgen(rskill: RSkillManifest) -> PolicyAdapter:
    from openral_data.policies.mimicgen import MimicGenPolicy

    return MimicGenPolicy(rskill)


def _sweep(rskill: RSkillManifest) -> PolicyAdapter:
    from openral_data.policies.sweep import SweepPolicy

    return SweepPolicy(rskill)


class Registry[F: Callable[..., object]](MutableMapping[str, F]):
    """Ids -> factories: the built-ins, then what `@REGISTRY.register("id")` (or `REGISTRY[id] = factory`) adds,
    then the installed plug-ins' entry points of `group` (loaded on first lookup; one that fails is recorded as a
    plug-in problem, never raised, and never replaces a built-in)."""

    def __init__(self, kind: str, group: str, builtins: dict[str, F]) -> None:
        self.kind = kind
        self.group = group
        self._builtins = dict(builtins)
        self._items = dict(builtins)
        self._origins = dict.fromkeys(builtins, "built-in")
        self._loaded = False

    def register(self, ident: str) -> Callable[[F], F]:
        """Decorator: `@SCENES.register("my_scene")` over a factory adds it under `ident` (a later one wins)."""

        def add(factory: F) -> F:
            self[ident] = factory
            return factory

        return add

    def origin(self, ident: str) -> str:
        """`built-in`, `plug-in <dist>` or `registered by <module>` (the module that defined the factory)."""
        self._load()
        return self._origins[ident]

    def __setitem__(self, ident: str, factory: F) -> None:
        self._items[ident] = factory
        builtin = self._builtins.get(ident) is factory
        defined = factory.make if isinstance(factory, SceneType) else factory  # a SceneType: where its factory is
        self._origins[ident] = "built-in" if builtin else f"registered by {getattr(defined, '__module__', '?')}"

    def __delitem__(self, ident: str) -> None:
        del self._items[ident]
        del self._origins[ident]

    def _load(self) -> None:
        if self._loaded:
            return
        self._loaded = True
        for name, dist, factory in manifests.plugin_objects(self.group):
            if isinstance(factory, ModuleType):  # a module: importing it ran its @register decorators
                continue
            problem = None
            if not callable(factory):
                problem = f"names a {type(factory).__name__}, not a factory"
            elif self._origins.get(name) == "built-in":
                problem = f"{self.kind} {name!r} is built in; the plug-in's is ignored"
            if problem:
                manifests.record_problem(manifests.PluginProblem(self.group, name, dist, problem))
                continue
            self._items[name] = cast(F, factory)
            self._origins[name] = f"plug-in {dist}"

    def __getitem__(self, ident: str) -> F:
        self._load()
        return self._items[ident]

    def __iter__(self) -> Iterator[str]:
        self._load()
        return iter(sorted(self._items))

    def __len__(self) -> int:
        self._load()
        return len(self._items)


SCENES: Registry[SceneFactory] = Registry(
    "scene type",
    "openral_data.scenes",
    {
        "mock": _mock_factory,
        "tabletop": _tabletop_factory(None),
        "tabletop_push": _tabletop_factory("push"),
        "tabletop_pick_place": _tabletop_factory("pick_place"),
        "mujoco_twin": _twin_factory,
        "gym_pusht": _pusht_factory,
        "gym_aloha": SceneType(_aloha_factory, _aloha_tasks),
        "libero": SceneType(_libero_factory, _libero_tasks),
        "maniskill": SceneType(_maniskill_factory, _maniskill_tasks),
        "robosuite": SceneType(_suite_factory("robosuite"), _robosuite_tasks),
        "metaworld": SceneType(_suite_factory("metaworld"), _metaworld_tasks),
    },
)
POLICIES: Registry[PolicyFactory] = Registry(
    "policy",
    "openral_data.policies",
    {
        "zero": _zero,
        "random": _random,
        "scripted_push": _scripted("ScriptedPush"),
        "scripted_pick_place": _scripted("ScriptedPickPlace"),
        "scripted_pick": _scripted("ScriptedPick"),
        "scripted_open_drawer": _scripted("ScriptedOpenDrawer"),
        "metaworld_expert": _metaworld_expert,
        "maniskill_expert": _maniskill_expert,
        "lerobot": _lerobot,
        "sweep": _sweep,
        "mimicgen": _mimicgen,
    },
)


def unknown(kind: str, value: str, valid: list[str]) -> OpenralError:
    """`unknown scene 'tabletop_psh'; did you mean 'tabletop_push'? (49 in all: openral-data list scenes)`."""
    listing = f"openral-data list {kind.lower()}s"
    return UsageError(f"unknown {kind} {value!r}; {choices_hint(value, sorted(valid), listing)}")


def scene_factory(scene_type: str, source: str) -> SceneFactory:
    if scene_type not in SCENES:
        raise ConfigError(
            f"{source}: scene.type: unknown scene type {scene_type!r}; valid: {', '.join(sorted(SCENES))}"
        )
    return SCENES[scene_type]


def task_lister(scene_type: str) -> TaskLister | None:
    """The lister of `scene_type`'s tasks; None for a scene type without tasks (or not registered)."""
    factory = SCENES.get(scene_type)
    return factory.tasks if isinstance(factory, SceneType) else None


def scene_types_with_tasks() -> list[str]:
    return [ident for ident in SCENES if task_lister(ident) is not None]


def policy_factory(rskill: RSkillManifest, source: str) -> PolicyFactory:
    if rskill.policy not in POLICIES:
        raise ConfigError(f"{source}: policy: unknown policy {rskill.policy!r}; valid: {', '.join(sorted(POLICIES))}")
    return POLICIES[rskill.policy]


# --- robots -----------------------------------------------------------------------------------------------


def robot_ids() -> list[str]:
    return manifests.ids("robots")


class RobotRegistry(Mapping[str, "RobotManifest"]):
    """ROBOTS: every `robots/<id>/robot.yaml` on the search path (`openral_data.manifests`), looked up on each
    access (adding a folder adds a robot). Looking up an unknown id raises an OpenralError listing the valid ones.
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
    from openral_data.schemas.base import load_model
    from openral_data.schemas.robot import RobotManifest

    path = manifests.find("robots", robot_id)
    if path is None:
        raise unknown("robot", robot_id, robot_ids())
    robot = load_model(RobotManifest, path)
    if robot.name != robot_id:
        raise ConfigError(f"{path}: name: {robot.name!r} must equal its folder name {robot_id!r}")
    return robot


ROBOTS = RobotRegistry()


# --- rSkills ----------------------------------------------------------------------------------------------


def rskill_ids() -> list[str]:
    return manifests.ids("rskills")


def resolve_rskill(ref: str) -> tuple[RSkillManifest, Path]:
    """An rSkill id (on the search path), a folder holding `rskill.yaml`, or a YAML file."""
    from openral_data.schemas.base import load_model
    from openral_data.schemas.rskill import RSkillManifest

    candidate = Path(ref).expanduser()
    if candidate.is_dir():
        candidate = candidate / "rskill.yaml"
    if not candidate.is_file():
        by_id = manifests.find("rskills", ref)
        if by_id is None:
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


def scene_files() -> dict[str, Path]:
    return {ident: entry.path for ident, entry in manifests.entries("scenes").items()}


def resolve_scene_path(ref: str) -> Path:
    """A path to a scene YAML, or a scene id (a scene file's stem) on the search path."""
    candidate = Path(ref).expanduser()
    if candidate.is_file():
        return candidate
    files = scene_files()
    if ref in files:
        return files[ref]
    if candidate.suffix in (".yaml", ".yml") or "/" in ref:
        raise ConfigError(f"{ref}: file not found")
    raise unknown("scene", ref, list(files))
