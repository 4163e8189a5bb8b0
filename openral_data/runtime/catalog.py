"""What this installation knows: every scene, rSkill and robot on the manifest search path (where each comes
from, what it overrides, whether it loads), the registered scene types and policies, and broken plug-ins.

`openral-data list` prints it as tables or as one JSON document (`Catalog.to_json`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from functools import partial

from openral_data import manifests
from openral_data.errors import OpenralError
from openral_data.runtime import registry
from openral_data.schemas.base import load_model
from openral_data.schemas.rskill import RSkillManifest
from openral_data.schemas.scene import load_scene

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
    builders: dict[str, Callable[[], list[Item]]] = {
        "scenes": _scenes,
        "rskills": _rskills,
        "robots": _robots,
        "scene_types": partial(_factories, registry.SCENES),
        "policies": partial(_factories, registry.POLICIES),
    }
    built = {name: builders[name]() for name in sections}
    return Catalog(built, plugin_problems())


def plugin_problems() -> list[manifests.PluginProblem]:
    """Every broken plug-in: all entry-point groups are loaded first (the registries load theirs lazily)."""
    len(registry.SCENES), len(registry.POLICIES)
    return manifests.plugin_problems()


def _entry_item(entry: manifests.Entry, fields: dict[str, object] | None, error: str | None) -> Item:
    return Item(entry.id, entry.origin, str(entry.path), entry.overrides, fields or {}, error)


def _scenes() -> list[Item]:
    out = []
    for entry in manifests.entries("scenes").values():
        try:
            sc = load_scene(entry.path)
        except OpenralError as exc:
            out.append(_entry_item(entry, None, str(exc)))
            continue
        spec = sc.scene
        fields: dict[str, object] = {
            "tier": sc.tier,
            "type": spec.type,
            "robot": spec.robot,
            "default_rskill": spec.default_rskill,
        }
        out.append(_entry_item(entry, fields, None))
    return out


def _rskills() -> list[Item]:
    out = []
    for entry in manifests.entries("rskills").values():
        try:
            rs = load_model(RSkillManifest, entry.path)
        except OpenralError as exc:
            out.append(_entry_item(entry, None, str(exc)))
            continue
        fields: dict[str, object] = {
            "policy": rs.policy,
            "embodiment_tags": list(rs.embodiment_tags),
            "state_dim": rs.state_contract.dim,
            "state_representation": rs.state_contract.representation,
            "action_dim": rs.action_contract.dim,
            "action_representation": rs.action_contract.representation,
            "cameras": list(rs.required_cameras),
        }
        out.append(_entry_item(entry, fields, None))
    return out


def _robots() -> list[Item]:
    """Each robot with the scenes on the search path that record it (what it runs in here; benchmark copies not
    repeated)."""
    scenes: dict[str, list[str]] = {}
    for scene in _scenes():
        robot = scene.fields.get("robot")
        if isinstance(robot, str) and scene.fields.get("tier") != "benchmark":
            scenes.setdefault(robot, []).append(scene.id)
    out = []
    for entry in manifests.entries("robots").values():
        try:
            rb = registry.load_robot(entry.id)
        except OpenralError as exc:
            out.append(_entry_item(entry, None, str(exc)))
            continue
        fields: dict[str, object] = {
            "embodiment_tags": list(rb.embodiment_tags),
            "joints": len(rb.joints),
            "state_dim": rb.observation.state.dim,
            "action_dim": rb.action.dim,
            "cameras": [c.name for c in rb.sensors.cameras],
            "scenes": scenes.get(rb.name, []),
            "description": rb.description,
        }
        out.append(_entry_item(entry, fields, None))
    return out


def _factories(reg: registry.Registry[registry.SceneFactory] | registry.Registry[registry.PolicyFactory]) -> list[Item]:
    return [Item(ident, reg.origin(ident)) for ident in reg]
