"""Malformed YAML files: scene, rSkill, robot, mapping, pipeline, replay --cameras (raw damage and bad fields)."""

from __future__ import annotations

import copy
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from tests.malformed.corpus.cases import case
from tests.support.bags import MAPPING
from tests.support.malformed import Workspace
from tests.support.scenes import mock_scene


@dataclass(frozen=True)
class Slot:
    """Where a YAML file goes, the command that reads it, the outputs it would write."""

    name: str
    file: str  # relative to the workspace root, or "home:<rel>" in the project home
    names: str  # regex of the file in the error line
    base: Callable[[Workspace], Any]
    argv: Callable[[Workspace, Path], list[str]]
    new: tuple[str, ...]

    def place(self, w: Workspace) -> Path:
        if self.file.startswith("home:"):
            p = w.home / self.file.removeprefix("home:")
            p.parent.mkdir(parents=True, exist_ok=True)
            return p
        return w.path(self.file)


def pipeline_doc(w: Workspace) -> Any:
    return {
        "name": "broken",
        "steps": [
            {
                "id": "rec",
                "record": {
                    "scenes": ["mock_pick"],
                    "rskills": ["random-mock"],
                    "seeds": {"start": 0, "count": 1},
                    "max_steps": 3,
                    "codec": "h264",
                },
            },
            {"id": "all", "merge": {"inputs": ["rec"]}},
        ],
    }


SLOTS = [
    Slot(
        "scene",
        "scene.yaml",
        r"scene\.yaml",
        lambda w: mock_scene(cameras=[("front", 64, 48), ("wrist", 32, 32)], max_steps=3, n_episodes=1),
        lambda w, p: ["record", "--scene", str(p), "--out", str(w.root / "o")],
        ("o",),
    ),
    Slot(
        "rskill",
        "rs/rskill.yaml",
        r"rs/rskill\.yaml",
        lambda w: w.repo_yaml("rskills/random-mock/rskill.yaml"),
        lambda w, p: ["record", "--rskill", str(p), "--max-steps", "3", "--out", str(w.root / "o")],
        ("o",),
    ),
    Slot(
        "robot",
        "home:robots/mock_arm/robot.yaml",
        r"mock_arm/robot\.yaml",
        lambda w: w.repo_yaml("robots/mock_arm/robot.yaml"),
        lambda w, p: ["record", "--max-steps", "3", "--out", str(w.root / "o")],
        ("o",),
    ),
    Slot(
        "mapping",
        "mapping.yaml",
        r"mapping\.yaml",
        lambda w: copy.deepcopy(MAPPING),
        lambda w, p: ["convert", str(w.bag), str(w.root / "o"), "--mapping", str(p)],
        ("o",),
    ),
    Slot(
        "pipeline",
        "p.yaml",
        r"p\.yaml",
        pipeline_doc,
        lambda w, p: ["pipeline", "run", str(p), "--workdir", str(w.root / "wd")],
        ("wd",),
    ),
    Slot(
        "cameras",
        "cams.yaml",
        r"cams\.yaml",
        lambda w: {"cameras": [{"name": "front", "width": 64, "height": 48}]},
        lambda w, p: [
            "replay",
            str(w.ds()),
            "--record",
            str(w.root / "rec"),
            "--cameras",
            str(p),
            "--out",
            str(w.root / "res"),
        ],
        ("rec", "res"),
    ),
]

RAW: dict[str, Callable[[Any], bytes | str | None]] = {
    "empty": lambda doc: b"",
    "not-utf8": lambda doc: b"scene: \xff\xfe\x00 broken\n",
    "latin1": lambda doc: yaml.safe_dump(doc).encode() + "# caf\u00e9\n".encode("latin-1"),
    "binary": lambda doc: bytes(range(256)),
    "top-list": lambda doc: "- a\n- b\n",
    "top-scalar": lambda doc: "42\n",
    "top-null": lambda doc: "~\n",
    "top-string": lambda doc: "just some words\n",
    "syntax": lambda doc: "a: [1, 2\n",
    "tab-indent": lambda doc: "a:\n\tb: 1\n",
    "duplicate-key": lambda doc: yaml.safe_dump(doc, sort_keys=False) + f"{next(iter(doc))}: again\n",
    "recursive-alias": lambda doc: "a: &x [*x]\n",
    "unhashable-key": lambda doc: "? [a, b]\n: 1\n",
    "directory": lambda doc: None,
    # a 5000-digit integer is over Python's int-from-text limit (#49: a traceback before)
    "5000-digit-integer": lambda doc: yaml.safe_dump(doc, sort_keys=False) + f"zz_number: {'9' * 5000}\n",
}


def _raw_case(slot: Slot, kind: str, make: Callable[[Any], bytes | str | None]) -> None:
    def build(w: Workspace) -> list[str]:
        p = slot.place(w)
        data = make(slot.base(w))
        if data is None:
            p.unlink(missing_ok=True)
            p.mkdir(parents=True)
        elif isinstance(data, str):
            p.write_text(data)
        else:
            p.write_bytes(data)
        return slot.argv(w, p)

    case(f"{slot.name}-{kind}", build, slot.names, slot.new)


for _slot in SLOTS:
    for _kind, _make in RAW.items():
        _raw_case(_slot, _kind, _make)


def _set(doc: Any, dotted: str, value: Any) -> None:
    """Set `a.b[0].c` in `doc` (a missing key is created); value `...` deletes it."""
    parts: list[str | int] = []
    for bit in dotted.split("."):
        name, _, rest = bit.partition("[")
        if name:
            parts.append(name)
        while rest:
            idx, _, rest = rest.partition("]")
            parts.append(int(idx))
            rest = rest.removeprefix("[")
    node = doc
    for part in parts[:-1]:
        node = node[part]
    if value is ...:
        del node[parts[-1]]
    else:
        node[parts[-1]] = value


NAN8 = [float("nan")] * 8
# (slot, field, value, regex of the field in the message)
FIELDS: list[tuple[str, str, Any, str]] = [
    ("scene", "scene.fps", 0, r"scene\.fps"),
    ("scene", "scene.fps", -20, r"scene\.fps"),
    ("scene", "scene.fps", "fast", r"scene\.fps"),
    ("scene", "scene.fps", 10**30, r"scene\.fps"),
    ("scene", "scene.fps", float("nan"), r"scene\.fps"),
    ("scene", "scene.fps", [20], r"scene\.fps"),
    ("scene", "scene.cameras", {"front": 1}, r"scene\.cameras"),
    ("scene", "scene.cameras", "front", r"scene\.cameras"),
    ("scene", "scene.cameras[0].width", 100000, r"scene\.cameras\[0\]\.width"),
    ("scene", "scene.cameras[0]", {"name": "front", "width": 100000, "height": 100000}, r"scene\.cameras\[0\]"),
    ("scene", "scene.cameras[0].height", -48, r"scene\.cameras\[0\]\.height"),
    (
        "scene",
        "scene.cameras",
        [{"name": f"c{i}", "width": 4096, "height": 4096} for i in range(5)],
        r"pixels per step",
    ),
    ("scene", "scene.cameras[0].width", "64px", r"scene\.cameras\[0\]\.width"),
    ("scene", "scene.cameras[0].width", 64.5, r"scene\.cameras\[0\]\.width"),
    ("scene", "scene.cameras[0].name", "../front", r"scene\.cameras\[0\]\.name"),
    ("scene", "scene.cameras[1].name", "front", r"duplicate camera names"),
    ("scene", "scene.cameras[0].fovy", float("inf"), r"scene\.cameras\[0\]\.fovy"),
    ("scene", "scene.id", "../escape", r"scene\.id"),
    ("scene", "scene.type", ["mock"], r"scene\.type"),
    ("scene", "scene.render", "yes", r"scene\.render"),
    ("scene", "scene.params", [1, 2], r"scene\.params"),
    ("scene", "scene.params.success_after", "soon", r"success_after"),
    ("scene", "scene.params.success_after", [], r"success_after"),
    ("scene", "scene.params.state_dim", 10**12, r"state"),
    ("scene", "scene.params.step_sleep", float("nan"), r"step_sleep"),
    ("scene", "scene.params.fault", {"kind": "meteor"}, r"fault"),
    ("scene", "scene", [1], r"scene"),
    ("scene", "task", None, r"task"),
    ("scene", "task.max_steps", 0, r"task\.max_steps"),
    ("scene", "task.instruction", "", r"task\.instruction"),
    ("scene", "seed", -1, r"seed"),
    ("scene", "seed", 2**70, r"seed"),
    ("scene", "n_episodes", -5, r"n_episodes"),
    ("scene", "n_episodes", "many", r"n_episodes"),
    ("scene", "tier", 3, r"tier"),
    ("scene", "tier", ..., r"tier"),
    ("rskill", "state_contract", [8], r"state_contract"),
    ("rskill", "state_contract.dim", "eight", r"state_contract\.dim"),
    ("rskill", "state_contract.dim", 0, r"state_contract\.dim"),
    ("rskill", "state_contract.dim", 10**12, r"state_contract"),
    ("rskill", "state_contract.names", "joint1", r"state_contract\.names"),
    ("rskill", "action_contract.low", [float("nan")] * 7, r"action_contract\.low"),
    ("rskill", "action_contract.high", [float("inf")] * 7, r"action_contract\.high"),
    ("rskill", "action_contract.low", [2] * 7, r"action_contract.*low must be <= high"),
    ("rskill", "action_contract.low", [0], r"action_contract.*low has 1 entries"),
    ("rskill", "embodiment_tags", "mock", r"embodiment_tags"),
    ("rskill", "embodiment_tags", [], r"embodiment_tags"),
    ("rskill", "policy", 5, r"policy"),
    ("rskill", "required_cameras", "front", r"required_cameras"),
    ("rskill", "policy_extras", [1], r"policy_extras"),
    ("rskill", "id", "../x", r"id"),
    ("rskill", "action_contract", ..., r"action_contract"),
    ("robot", "observation", [1], r"observation"),
    ("robot", "observation.state.dim", 0, r"observation\.state\.dim"),
    ("robot", "action.dim", "seven", r"action\.dim"),
    ("robot", "joints", {"j": 1}, r"joints"),
    ("robot", "joints[0].limits", [1.0, -1.0], r"joints\[0\]"),
    ("robot", "joints[0].limits", [float("nan"), 1.0], r"joints\[0\]\.limits"),
    ("robot", "joints[0].type", "telescopic", r"joints\[0\]\.type"),
    ("robot", "sensors.cameras[0].width", 100000, r"sensors\.cameras\[0\]\.width"),
    ("robot", "embodiment_tags", 3, r"embodiment_tags"),
    ("robot", "name", "other_arm", r"name"),
    ("robot", "safety", {"workspace": {"x": [1, 0], "y": [0, 1], "z": [0, 1]}}, r"safety\.workspace"),
    ("robot", "safety", {"max_state_age": 0}, r"safety\.max_state_age"),
    ("robot", "hardware", {"driver": "warp", "port": "/dev/null"}, r"hardware\.driver"),
    ("robot", "sim", [1], r"sim"),
    ("mapping", "fps", 0, r"fps"),
    ("mapping", "fps", "ten", r"fps"),
    ("mapping", "fps", float("nan"), r"fps"),
    ("mapping", "fps", 10**40, r"fps"),
    ("mapping", "state", ["/joint_states"], r"state"),
    ("mapping", "state.field", "a..b", r"state"),
    ("mapping", "state.joints", [], r"state"),
    ("mapping", "cameras", ["/cam/image_raw"], r"cameras"),
    ("mapping", "cameras", {"../front": "/cam/image_raw"}, r"camera name"),
    ("mapping", "align", {"max_staleness": -1}, r"align\.max_staleness"),
    ("mapping", "align", {"max_staleness": float("nan")}, r"align\.max_staleness"),
    ("mapping", "align", {"method": "telepathy"}, r"align\.method"),
    ("mapping", "episodes", {"split": "marker"}, r"episodes"),
    ("mapping", "episodes", {"split": "gap", "gap": 0}, r"episodes\.gap"),
    ("mapping", "task", "fixed text", r"exactly one of task"),
    ("mapping", "reward", "x", r"reward"),
    ("mapping", "success", {}, r"success"),
    ("mapping", "action", ..., r"action"),
    ("mapping", "state", {"parts": []}, r"state.*parts must be a non-empty list"),
    ("mapping", "state", {"parts": {"topic": "/joint_states"}}, r"state\.parts"),
    ("mapping", "state", {"topic": "/joint_states", "parts": [{"topic": "/cmd"}]}, r"state.*topic beside parts"),
    ("mapping", "action", {"parts": [{"field": "data"}]}, r"action\.parts\[0\]\.topic"),
    ("mapping", "action", {"parts": [{"topic": "/cmd", "field": "a..b"}]}, r"action\.parts\[0\]"),
    (
        "mapping",
        "state",
        {"parts": [{"topic": "/joint_states", "joints": ["j1"]}, {"topic": "/joint_states", "joints": ["j1"]}]},
        r"state.*parts\[0\] and parts\[1\] both name a dimension 'j1'",
    ),
    ("pipeline", "steps", {"rec": 1}, r"steps"),
    ("pipeline", "steps", [], r"steps"),
    ("pipeline", "name", "../escape", r"name"),
    ("pipeline", "name", 5, r"name"),
    ("pipeline", "steps[0].id", "../rec", r"steps\[0\]"),
    ("pipeline", "steps[0].record.seeds.count", 0, r"steps\[0\]\.record\.seeds\.count"),
    ("pipeline", "steps[0].record.seeds.start", -1, r"steps\[0\]\.record\.seeds\.start"),
    ("pipeline", "steps[0].record.seeds.start", 2**70, r"steps\[0\]\.record\.seeds.*uint32"),
    ("pipeline", "steps[0].record.scenes", "mock_pick", r"steps\[0\]\.record\.scenes"),
    ("pipeline", "steps[0].record.workers", 0, r"steps\[0\]\.record\.workers"),
    ("pipeline", "steps[0].record.codec", "mpeg2", r"steps\[0\]\.record\.codec"),
    ("pipeline", "steps[0].record.max_steps", 0, r"steps\[0\]\.record\.max_steps"),
    ("pipeline", "steps[0].merge", {"inputs": ["rec"]}, r"steps\[0\]"),
    ("pipeline", "steps[1].merge.inputs", ["nope"], r"steps\[1\]\.merge\.inputs\[0\]"),
    ("pipeline", "steps[1].id", "rec", r"steps\[1\]\.id"),
    ("pipeline", "steps[1].merge.order", "random", r"steps\[1\]\.merge\.order"),
    ("cameras", "cameras", [], r"cameras"),
    ("cameras", "cameras[0].width", 100000, r"cameras\[0\]\.width"),
    ("cameras", "cameras[0]", {"name": "front", "width": 100000, "height": 100000}, r"cameras\[0\]"),
    ("cameras", "cameras[0].height", "tall", r"cameras\[0\]\.height"),
    ("cameras", "render", [1], r"render"),
]


def _field_case(slot: Slot, field: str, value: Any, names: str) -> None:
    def build(w: Workspace) -> list[str]:
        doc = slot.base(w)
        _set(doc, field, value)
        p = slot.place(w)
        p.write_text(yaml.safe_dump(doc, sort_keys=False))
        return slot.argv(w, p)

    what = "<deleted>" if value is ... else repr(value).replace(" ", "")
    if len(what) > 24:
        what = what[:21] + "..."
    case(f"{slot.name}-{field}={what}", build, f"{slot.names}.*{names}", slot.new)


_BY_NAME = {s.name: s for s in SLOTS}
for _slot_name, _field, _value, _names in FIELDS:
    _field_case(_BY_NAME[_slot_name], _field, _value, _names)
