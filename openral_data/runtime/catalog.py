"""What this installation knows: every scene, rSkill and robot on the manifest search path (where each comes
from, what it overrides, whether it loads), the registered scene types and policies, and broken plug-ins.

`openral-data list` prints it as tables or as one JSON document (`Catalog.to_json`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import asdict, dataclass, field, replace
from functools import partial

from openral_data import manifests
from openral_data.errors import OpenralError
from openral_data.runtime import registry
from openral_data.runtime.catalog_cache import CatalogCache, Loaded

__all__ = ["FIELDS", "SECTIONS", "Catalog", "Item", "catalog", "plugin_problems"]

SECTIONS = ("scenes", "rskills", "robots", "scene_types", "policies")
# each section's own fields, in order (docs/scripting.md); `null` where an entry does not load
FIELDS: dict[str, tuple[str, ...]] = {
    "scenes": ("tier", "type", "robot", "default_rskill"),
    "rskills": (
        "policy",
        "embodiment_tags",
        "state_dim",
        "state_representation",
        "action_dim",
        "action_representation",
        "cameras",
    ),
    "robots": ("embodiment_tags", "joints", "state_dim", "action_dim", "cameras", "scenes", "description"),
    "scene_types": (),
    "policies": (),
}


@dataclass(frozen=True)
class Item:
    """One entry. `fields` are the kind's own columns (empty when `error` says why it does not load)."""

    id: str
    origin: str
    path: str | None = None
    overrides: tuple[str, ...] = ()
    fields: dict[str, object] = field(default_factory=dict)
    error: str | None = None


@dataclass(frozen=True)
class Catalog:
    sections: dict[str, list[Item]]
    plugin_problems: list[manifests.PluginProblem]

    def to_json(self) -> dict[str, object]:
        """Every section by name (null when not built), each a list of `{id, origin, path, overrides, error,
        <FIELDS>}`, then the plug-in problems."""
        doc: dict[str, object] = {}
        for name in SECTIONS:
            items = self.sections.get(name)
            doc[name] = (
                None
                if items is None
                else [
                    {
                        "id": it.id,
                        "origin": it.origin,
                        "path": it.path,
                        "overrides": list(it.overrides),
                        "error": it.error,
                        **{key: it.fields.get(key) for key in FIELDS[name]},
                    }
                    for it in items
                ]
            )
        doc["plugin_problems"] = [asdict(p) for p in self.plugin_problems]
        return doc


def catalog(sections: tuple[str, ...] = SECTIONS) -> Catalog:
    cache = CatalogCache()  # each manifest's fields as last loaded, while its file is unchanged
    builders: dict[str, Callable[[], list[Item]]] = {
        "scenes": partial(_manifests, "scenes", _scene_fields, cache),
        "rskills": partial(_manifests, "rskills", _rskill_fields, cache),
        "robots": partial(_manifests, "robots", _robot_fields, cache),
        "scene_types": partial(_factories, registry.SCENES),
        "policies": partial(_factories, registry.POLICIES),
    }
    built = {name: builders[name]() for name in sections}
    if "robots" in built:
        built["robots"] = _with_scenes(built["robots"], built.get("scenes") or builders["scenes"]())
    cache.save()
    return Catalog(built, plugin_problems())


def plugin_problems() -> list[manifests.PluginProblem]:
    """Every broken plug-in: all entry-point groups are loaded first (the registries load theirs lazily)."""
    len(registry.SCENES), len(registry.POLICIES)
    return manifests.plugin_problems()


def _manifests(
    kind: manifests.Kind, fields_of: Callable[[manifests.Entry], dict[str, object]], cache: CatalogCache
) -> list[Item]:
    """Every manifest of `kind` with its fields, or the one-line error it fails to load with."""
    out = []
    for entry in manifests.entries(kind).values():
        fields, error = cache.loaded(kind, entry.path, partial(_load, fields_of, entry))
        out.append(Item(entry.id, entry.origin, str(entry.path), entry.overrides, fields or {}, error))
    return out


def _load(fields_of: Callable[[manifests.Entry], dict[str, object]], entry: manifests.Entry) -> Loaded:
    try:
        return fields_of(entry), None
    except OpenralError as exc:
        return None, str(exc)


def _with_scenes(robots: list[Item], scenes: list[Item]) -> list[Item]:
    """Each robot with the scenes on the search path that record it (what it runs in here; benchmark copies not
    repeated). Not cached with the robot: it depends on the scene files."""
    found: dict[str, list[str]] = {}
    for scene in scenes:
        robot = scene.fields.get("robot")
        if isinstance(robot, str) and scene.fields.get("tier") != "benchmark":
            found.setdefault(robot, []).append(scene.id)
    return [
        replace(it, fields={**it.fields, "scenes": found.get(it.id, [])}) if it.error is None else it for it in robots
    ]


def _scene_fields(entry: manifests.Entry) -> dict[str, object]:
    from openral_data.schemas.scene import load_scene

    sc = load_scene(entry.path)
    spec = sc.scene
    return {"tier": sc.tier, "type": spec.type, "robot": spec.robot, "default_rskill": spec.default_rskill}


def _rskill_fields(entry: manifests.Entry) -> dict[str, object]:
    from openral_data.schemas.base import load_model
    from openral_data.schemas.rskill import RSkillManifest

    rs = load_model(RSkillManifest, entry.path)
    return {
        "policy": rs.policy,
        "embodiment_tags": list(rs.embodiment_tags),
        "state_dim": rs.state_contract.dim,
        "state_representation": rs.state_contract.representation,
        "action_dim": rs.action_contract.dim,
        "action_representation": rs.action_contract.representation,
        "cameras": list(rs.required_cameras),
    }


def _robot_fields(entry: manifests.Entry) -> dict[str, object]:
    rb = registry.load_robot(entry.id)
    return {
        "embodiment_tags": list(rb.embodiment_tags),
        "joints": len(rb.joints),
        "state_dim": rb.observation.state.dim,
        "action_dim": rb.action.dim,
        "cameras": [c.name for c in rb.sensors.cameras],
        "description": rb.description,
    }


def _factories(reg: registry.Registry[registry.SceneFactory] | registry.Registry[registry.PolicyFactory]) -> list[Item]:
    return [Item(ident, reg.origin(ident)) for ident in reg]
