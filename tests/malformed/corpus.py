"""The malformed-input corpus: each case builds one bad input in a fresh workspace and names the command line
that must refuse it with exit 2 and one `error:` line naming the file or option (and the field).

A case is (id, build, names, new): `build(w)` makes the bad input under `w.root` and returns the arguments;
`names` is a regex the error line must match; `new` are outputs (relative to `w.root`) that must not exist
afterwards. Everything else under `w.root` must be byte-identical before and after.
"""

from __future__ import annotations

import copy
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from tests.support.bags import MAPPING
from tests.support.malformed import Workspace
from tests.support.scenes import mock_scene

Build = Callable[[Workspace], list[str]]


@dataclass(frozen=True)
class Case:
    id: str
    build: Build
    names: str
    new: tuple[str, ...] = ()


CASES: list[Case] = []


def case(id: str, build: Build, names: str, new: tuple[str, ...] = ()) -> None:
    assert all(c.id != id for c in CASES), id
    CASES.append(Case(id, build, names, new))


# ---------------------------------------------------------------------------------------------------------------
# YAML files: scene, rSkill, robot, mapping, pipeline, replay --cameras


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


def _pipeline(w: Workspace) -> Any:
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
        _pipeline,
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


# ---------------------------------------------------------------------------------------------------------------
# A damaged dataset, read by each command that reads it

DATA = "data/chunk-000/file-000.parquet"
EPISODES = "meta/episodes/chunk-000/file-000.parquet"
VIDEO = "videos/observation.images.front/chunk-000/file-000.mp4"


def _info(w: Workspace, ds: Path, **changes: Any) -> None:
    import json

    info = json.loads((ds / "meta/info.json").read_text())
    for key, value in changes.items():
        if value is ...:
            del info[key]
        else:
            info[key] = value
    (ds / "meta/info.json").write_text(json.dumps(info))


def _to_folder(path: Path) -> None:
    path.unlink()
    path.mkdir()


def _cut(path: Path, keep: float) -> None:
    data = path.read_bytes()
    path.write_bytes(data[: int(len(data) * keep)])


# damage id -> (what it does to the copy, regex of the file the error must name)
DAMAGE: dict[str, tuple[Callable[[Workspace, Path], object], str]] = {
    "info-not-utf8": (lambda w, d: (d / "meta/info.json").write_bytes(b'{"fps": "\xff"}'), r"info\.json"),
    "info-invalid-json": (lambda w, d: (d / "meta/info.json").write_text("{fps: 20"), r"info\.json"),
    "info-empty": (lambda w, d: (d / "meta/info.json").write_bytes(b""), r"info\.json"),
    "info-list": (lambda w, d: (d / "meta/info.json").write_text("[1, 2]"), r"info\.json"),
    "info-directory": (lambda w, d: _to_folder(d / "meta/info.json"), r"info\.json"),
    "info-fps-0": (lambda w, d: _info(w, d, fps=0), r"info\.json.*fps"),
    "info-fps-string": (lambda w, d: _info(w, d, fps="fast"), r"info\.json.*fps"),
    "info-fps-missing": (lambda w, d: _info(w, d, fps=...), r"info\.json.*fps"),
    "info-features-list": (lambda w, d: _info(w, d, features=["action"]), r"info\.json.*features"),
    "info-features-missing": (lambda w, d: _info(w, d, features=...), r"info\.json.*features"),
    "episodes-garbage": (lambda w, d: (d / EPISODES).write_bytes(b"PAR1 not really PAR1"), r"meta/episodes/"),
    "episodes-empty": (lambda w, d: (d / EPISODES).write_bytes(b""), r"meta/episodes/"),
    "episodes-truncated": (lambda w, d: _cut(d / EPISODES, 0.5), r"meta/episodes/"),
    "episodes-folder": (lambda w, d: _to_folder(d / EPISODES), r"meta/episodes/"),
    "tasks-garbage": (lambda w, d: (d / "meta/tasks.parquet").write_bytes(b"\x00" * 64), r"tasks\.parquet"),
    "tasks-missing": (lambda w, d: (d / "meta/tasks.parquet").unlink(), r"tasks\.parquet"),
    "data-garbage": (lambda w, d: (d / DATA).write_bytes(b"garbage" * 10), r"data/chunk-000/file-000\.parquet"),
    "data-empty": (lambda w, d: (d / DATA).write_bytes(b""), r"data/chunk-000/file-000\.parquet"),
    "data-truncated": (lambda w, d: _cut(d / DATA, 0.6), r"data/chunk-000/file-000\.parquet"),
    "data-missing": (lambda w, d: (d / DATA).unlink(), r"data/chunk-000/file-000\.parquet"),
    "data-folder": (lambda w, d: _to_folder(d / DATA), r"data/chunk-000/file-000\.parquet"),
    "video-empty": (lambda w, d: (d / VIDEO).write_bytes(b""), r"observation\.images\.front"),
    "video-truncated": (lambda w, d: _cut(d / VIDEO, 0.3), r"observation\.images\.front"),
    "video-missing": (lambda w, d: (d / VIDEO).unlink(), r"observation\.images\.front"),
    "video-folder": (lambda w, d: _to_folder(d / VIDEO), r"observation\.images\.front"),
    "video-garbage": (
        lambda w, d: (d / VIDEO).write_bytes(b"\x00\x00\x00\x18ftypgarbage" * 50),
        r"observation\.images",
    ),
    "openral-invalid": (lambda w, d: (d / "meta/openral.json").write_text("{"), r"openral\.json"),
    "openral-list": (lambda w, d: (d / "meta/openral.json").write_text("[]"), r"openral\.json"),
}

# command id -> (argv for the damaged dataset `d`, the outputs it would write)
READERS: dict[str, tuple[Callable[[Workspace, Path], list[str]], tuple[str, ...]]] = {
    "info": (lambda w, d: ["info", str(d)], ()),
    "stats": (lambda w, d: ["stats", str(d), "--format", "json"], ()),
    "convert": (lambda w, d: ["convert", str(d), str(w.root / "bags")], ("bags",)),
    "replay": (lambda w, d: ["replay", str(d), "--out", str(w.root / "res")], ("res",)),
    "delete": (lambda w, d: ["episodes", "delete", str(d), "--episodes", "0", "--out", str(w.root / "new")], ("new",)),
    "split": (
        lambda w, d: [
            "episodes",
            "split",
            str(d),
            "--episodes",
            "0",
            "--out",
            str(w.root / "a"),
            "--rest",
            str(w.root / "b"),
        ],
        ("a", "b"),
    ),
    "merge": (lambda w, d: ["episodes", "merge", str(w.ds("good")), str(d), "--out", str(w.root / "m")], ("m",)),
    "view": (lambda w, d: ["view", str(d), "--save", str(w.root / "v.rrd")], ("v.rrd",)),
    "reencode": (lambda w, d: ["videos", "reencode", str(d), "--codec", "h264", "--out", str(w.root / "v")], ("v",)),
    "recompute": (lambda w, d: ["stats", "recompute", str(d), "--out", str(w.root / "r")], ("r",)),
}

# which files each command reads (a damage elsewhere is not its business)
READS: dict[str, set[str]] = {
    "info": {"info", "episodes", "tasks"},
    "stats": {"info", "episodes", "tasks", "data", "openral"},
    "convert": {"info", "episodes", "tasks", "data", "video", "openral"},
    "replay": {"info", "episodes", "tasks", "data", "openral"},
    "delete": {"info", "episodes", "tasks", "data", "video", "openral"},
    "split": {"info", "episodes", "tasks", "data", "video", "openral"},
    "merge": {"info", "episodes", "tasks", "data", "video", "openral"},
    "view": {"info", "episodes", "tasks", "data", "video"},
    "reencode": {"info", "episodes", "tasks", "data", "video", "openral"},
    "recompute": {"info", "episodes", "tasks", "data", "video", "openral"},
}


# what a command does not read, and so rightly does not refuse
UNREAD = {
    "stats-tasks-missing",
    "stats-data-missing",
    "convert-openral-invalid",
    "convert-openral-list",
    "convert-info-directory",
    "view-tasks-garbage",
    "view-tasks-missing",
}


def _damage_case(reader: str, damage: str) -> None:
    argv, new = READERS[reader]
    hurt, names = DAMAGE[damage]

    def build(w: Workspace) -> list[str]:
        d = w.ds()
        hurt(w, d)
        return argv(w, d)

    case(f"{reader}-{damage}", build, names, new)


for _reader, _reads in READS.items():
    for _damage in DAMAGE:
        if _damage.split("-")[0] in _reads and f"{_reader}-{_damage}" not in UNREAD:
            _damage_case(_reader, _damage)


# ---------------------------------------------------------------------------------------------------------------
# Damaged replay results, read by stats and view --results


def _summary(r: Path, **changes: Any) -> None:
    import json

    summary = json.loads((r / "summary.json").read_text())
    summary.update(changes)
    (r / "summary.json").write_text(json.dumps(summary))


RESULTS_DAMAGE: dict[str, tuple[Callable[[Path], object], str]] = {
    "summary-not-utf8": (lambda r: (r / "summary.json").write_bytes(b'{"kind": "\xff"}'), r"summary\.json"),
    "summary-invalid-json": (lambda r: (r / "summary.json").write_text("{"), r"summary\.json"),
    "summary-list": (lambda r: (r / "summary.json").write_text("[]"), r"summary\.json"),
    "summary-format": (lambda r: _summary(r, format="other/9"), r"summary\.json: format"),
    "summary-kind": (lambda r: _summary(r, kind=["replay"]), r"summary\.json: kind"),
    "episodes-garbage": (lambda r: (r / "episodes.parquet").write_bytes(b"PAR1xxxxPAR1"), r"episodes\.parquet"),
    "episodes-empty": (lambda r: (r / "episodes.parquet").write_bytes(b""), r"episodes\.parquet"),
    "episodes-missing": (lambda r: (r / "episodes.parquet").unlink(), r"episodes\.parquet"),
    "steps-garbage": (lambda r: (r / "steps.parquet").write_bytes(b"\x00" * 99), r"steps\.parquet"),
    "steps-truncated": (lambda r: _cut(r / "steps.parquet", 0.5), r"steps\.parquet"),
    "steps-folder": (lambda r: _to_folder(r / "steps.parquet"), r"steps\.parquet"),
}
RESULTS_READERS: dict[str, tuple[Callable[[Workspace, Path], list[str]], tuple[str, ...]]] = {
    "stats": (lambda w, r: ["stats", str(r), "--format", "json"], ()),
    "view": (lambda w, r: ["view", str(w.ds()), "--results", str(r), "--save", str(w.root / "v.rrd")], ("v.rrd",)),
}


def _results_case(reader: str, damage: str) -> None:
    argv, new = RESULTS_READERS[reader]
    hurt, names = RESULTS_DAMAGE[damage]

    def build(w: Workspace) -> list[str]:
        r = w.res()
        hurt(r)
        return argv(w, r)

    case(f"{reader}-results-{damage}", build, names, new)


for _reader in RESULTS_READERS:
    for _damage in RESULTS_DAMAGE:
        _results_case(_reader, _damage)


# ---------------------------------------------------------------------------------------------------------------
# Options: episode selections, numbers, names


def _argv_case(id: str, argv: Callable[[Workspace], list[str]], names: str, new: tuple[str, ...] = ()) -> None:
    case(id, argv, names, new)


SELECTIONS = {
    "open-end": "1-",
    "open-start": "-1",
    "word": "first",
    "empty": "",
    "empty-part": "0,,1",
    "duplicate": "0,0",
    "out-of-range": "5",
    "reversed": "1-0",
    "range-past-end": "0-99",
    "underscore": "1_0",
    "arabic-digit": "\u0661",
    "space-inside": "0 1",
    "huge": "9" * 5000,
    "triple-range": "0-1-2",
}
SELECTORS: dict[str, tuple[Callable[[Workspace, str], list[str]], tuple[str, ...]]] = {
    "convert": (lambda w, sel: ["convert", str(w.ds()), str(w.root / "bags"), "--episodes", sel], ("bags",)),
    "replay": (lambda w, sel: ["replay", str(w.ds()), "--episodes", sel, "--out", str(w.root / "res")], ("res",)),
    "delete": (
        lambda w, sel: ["episodes", "delete", str(w.ds()), "--episodes", sel, "--out", str(w.root / "new")],
        ("new",),
    ),
    "split": (
        lambda w, sel: ["episodes", "split", str(w.ds()), "--episodes", sel, "--out", str(w.root / "a")],
        ("a",),
    ),
    "tasks-set": (
        lambda w, sel: ["tasks", "set", str(w.ds()), "--episodes", sel, "--task", "x", "--out", str(w.root / "t")],
        ("t",),
    ),
}


def _selection_case(cmd: str, what: str, sel: str) -> None:
    argv, new = SELECTORS[cmd]
    _argv_case(f"{cmd}-select-{what}", lambda w: argv(w, sel), r"--episodes", new)


for _cmd in SELECTORS:
    for _what, _sel in SELECTIONS.items():
        _selection_case(_cmd, _what, _sel)


def _record(*extra: str) -> Callable[[Workspace], list[str]]:
    return lambda w: ["record", "--max-steps", "3", "--out", str(w.root / "o"), *extra]


def _hal(*extra: str) -> Callable[[Workspace], list[str]]:
    return lambda w: ["record", "--hal", "mock_arm", *extra, "--out", str(w.root / "o")]


def _replay(*extra: str) -> Callable[[Workspace], list[str]]:
    return lambda w: ["replay", str(w.ds()), "--out", str(w.root / "res"), *extra]


def _videos(cmd: str, *extra: str) -> Callable[[Workspace], list[str]]:
    return lambda w: ["videos", cmd, str(w.ds()), *extra, "--out", str(w.root / "v")]


OPTIONS: list[tuple[str, Callable[[Workspace], list[str]], str, tuple[str, ...]]] = [
    ("videos-codec-unknown", _videos("reencode", "--codec", "vp9"), r"--codec", ("v",)),
    ("videos-size-not-wxh", _videos("reencode", "--codec", "av1", "--size", "64"), r"--size", ("v",)),
    ("videos-size-too-small", _videos("reencode", "--codec", "av1", "--size", "16x16"), r"--size", ("v",)),
    ("videos-size-odd", _videos("reencode", "--codec", "h264", "--size", "33x32"), r"--size", ("v",)),
    ("videos-camera-unknown", _videos("reencode", "--codec", "av1", "--camera", "nope"), r"--camera", ("v",)),
    (
        "videos-camera-not-video",
        _videos("reencode", "--codec", "av1", "--camera", "observation.state"),
        r"--camera: observation\.state",
        ("v",),
    ),
    ("videos-out-and-in-place", _videos("reencode", "--codec", "av1", "--in-place"), r"--out", ("v",)),
    ("encode-images-codec-unknown", _videos("encode-images", "--codec", "mpeg2"), r"--codec", ("v",)),
    ("encode-images-camera-not-image", _videos("encode-images", "--camera", "front"), r"--camera", ("v",)),
    ("encode-images-no-image-camera", _videos("encode-images"), r"ds: has no image cameras", ("v",)),
    ("record-seed-2**70", _record("--seed", str(2**70)), r"--seed", ("o",)),
    ("record-seed-negative", _record("--seed", "-1"), r"--seed", ("o",)),
    ("record-seed-past-uint32", _record("--seed", str(2**32 - 1), "--n-episodes", "2"), r"--seed", ("o",)),
    ("record-n-episodes-negative", _record("--n-episodes", "-3"), r"--n-episodes", ("o",)),
    (
        "record-max-steps-zero",
        lambda w: ["record", "--max-steps", "0", "--out", str(w.root / "o")],
        r"--max-steps",
        ("o",),
    ),
    ("record-format-unknown", _record("--format", "hdf5"), r"--format", ("o",)),
    ("record-format-empty", _record("--format", ""), r"--format", ("o",)),
    ("record-image-format-unknown", _record("--format", "mcap", "--image-format", "gif"), r"--image-format", ("o",)),
    ("record-workers-zero", _record("--workers", "0"), r"--workers", ("o",)),
    ("record-workers-negative", _record("--workers", "-2"), r"--workers", ("o",)),
    ("record-executor-unknown", _record("--workers", "2", "--executor", "slurm"), r"--executor", ("o",)),
    ("record-mode-without-hal", _record("--mode", "real"), r"--mode", ("o",)),
    (
        "record-resume-not-a-dataset",
        lambda w: ["record", "--resume", "--out", str(w.path("empty/x").parent)],
        r"empty",
        (),
    ),
    ("record-robot-unknown", _record("--robot", "r2d2"), r"r2d2", ("o",)),
    ("record-rskill-unknown", _record("--rskill", "nope"), r"nope", ("o",)),
    ("record-scene-unknown", _record("--scene", "nowhere"), r"nowhere", ("o",)),
    ("record-scene-missing-file", _record("--scene", "missing/scene.yaml"), r"missing/scene\.yaml", ("o",)),
    ("hal-robot-unknown", lambda w: ["record", "--hal", "r2d2", "--out", str(w.root / "o")], r"r2d2", ("o",)),
    (
        "hal-fps-zero",
        _hal("--fps", "0"),
        r"--fps",
        ("o",),
    ),
    (
        "hal-fps-huge",
        _hal("--fps", str(10**6)),
        r"--fps",
        ("o",),
    ),
    (
        "hal-mode-unknown",
        _hal("--mode", "dream"),
        r"--mode",
        ("o",),
    ),
    (
        "hal-safety-unknown",
        _hal("--safety", "yolo"),
        r"--safety",
        ("o",),
    ),
    (
        "hal-staleness-nan",
        _hal("--staleness", "nan"),
        r"--staleness",
        ("o",),
    ),
    (
        "hal-staleness-negative",
        _hal("--staleness", "-1"),
        r"--staleness",
        ("o",),
    ),
    (
        "hal-seed-2**70",
        _hal("--seed", str(2**70)),
        r"--seed",
        ("o",),
    ),
    (
        "hal-with-resume",
        _hal("--resume"),
        r"--resume",
        ("o",),
    ),
    ("replay-tolerance-nan", _replay("--tolerance", "nan"), r"--tolerance", ("res",)),
    ("replay-tolerance-negative", _replay("--tolerance", "-1"), r"--tolerance", ("res",)),
    ("replay-tolerance-inf", _replay("--tolerance", "inf"), r"--tolerance", ("res",)),
    ("replay-mode-unknown", _replay("--mode", "rewind"), r"--mode", ("res",)),
    ("replay-policy-without-rskill", _replay("--mode", "policy"), r"--rskill", ("res",)),
    ("replay-rskill-with-actions", _replay("--rskill", "random-mock"), r"--rskill", ("res",)),
    (
        "replay-max-steps-zero",
        _replay("--mode", "closed-loop", "--rskill", "random-mock", "--max-steps", "0"),
        r"--max-steps",
        ("res",),
    ),
    (
        "replay-format-unknown",
        lambda w: [
            "replay",
            str(w.ds()),
            "--out",
            str(w.root / "res"),
            "--record",
            str(w.root / "rec"),
            "--format",
            "avi",
        ],
        r"--format",
        ("res", "rec"),
    ),
    ("replay-cameras-without-record", _replay("--cameras", "cams.yaml"), r"--cameras", ("res",)),
    (
        "replay-dataset-missing",
        lambda w: ["replay", str(w.root / "nothing"), "--out", str(w.root / "res")],
        r"nothing",
        ("res",),
    ),
    ("stats-by-unknown", lambda w: ["stats", str(w.ds()), "--by", "colour"], r"--by", ()),
    ("stats-memory-limit-bogus", lambda w: ["stats", str(w.ds()), "--memory-limit", "lots"], r"memory", ()),
    ("stats-sql-invalid", lambda w: ["stats", str(w.ds()), "--sql", "SELEC 1"], r"", ()),
    ("stats-path-missing", lambda w: ["stats", str(w.root / "nothing")], r"nothing", ()),
    ("stats-not-a-dataset", lambda w: ["stats", str(w.path("plain/x").parent)], r"plain", ()),
    (
        "view-episode-negative",
        lambda w: ["view", str(w.ds()), "--episode", "-1", "--save", str(w.root / "v.rrd")],
        r"--episode",
        ("v.rrd",),
    ),
    (
        "view-episode-past-end",
        lambda w: ["view", str(w.ds()), "--episode", "7", "--save", str(w.root / "v.rrd")],
        r"--episode",
        ("v.rrd",),
    ),
    (
        "view-results-missing",
        lambda w: ["view", str(w.ds()), "--results", str(w.root / "nothing"), "--save", str(w.root / "v.rrd")],
        r"nothing",
        ("v.rrd",),
    ),
    (
        "view-path-missing",
        lambda w: ["view", str(w.root / "nothing"), "--save", str(w.root / "v.rrd")],
        r"nothing",
        ("v.rrd",),
    ),
    (
        "merge-order-unknown",
        lambda w: ["episodes", "merge", str(w.ds()), str(w.ds("ds2")), "--out", str(w.root / "m"), "--order", "random"],
        r"--order",
        ("m",),
    ),
    (
        "merge-not-a-dataset",
        lambda w: ["episodes", "merge", str(w.ds()), str(w.path("plain/x").parent), "--out", str(w.root / "m")],
        r"plain",
        ("m",),
    ),
    (
        "delete-every-episode",
        lambda w: ["episodes", "delete", str(w.ds()), "--episodes", "0-1", "--out", str(w.root / "new")],
        r"--episodes: 0-1 would delete every episode",
        ("new",),
    ),
    (
        "delete-in-place-and-out",
        lambda w: ["episodes", "delete", str(w.ds()), "--episodes", "0", "--in-place", "--out", str(w.root / "new")],
        r"--in-place|--out",
        ("new",),
    ),
    (
        "convert-image-format-unknown",
        lambda w: ["convert", str(w.ds()), str(w.root / "bags"), "--image-format", "gif"],
        r"--image-format",
        ("bags",),
    ),
    (
        "convert-mapping-for-dataset",
        lambda w: ["convert", str(w.ds()), str(w.root / "bags"), "--mapping", str(w.yaml("m.yaml", MAPPING))],
        r"--mapping",
        ("bags",),
    ),
    (
        "convert-episodes-for-bag",
        lambda w: ["convert", str(w.bag), str(w.root / "o"), "--episodes", "0"],
        r"--episodes",
        ("o",),
    ),
    ("convert-src-missing", lambda w: ["convert", str(w.root / "nothing"), str(w.root / "o")], r"nothing", ("o",)),
    (
        "pipeline-file-missing",
        lambda w: ["pipeline", "run", str(w.root / "nothing.yaml"), "--workdir", str(w.root / "wd")],
        r"nothing\.yaml",
        ("wd",),
    ),
    (
        "filter-where-bad-sql",
        lambda w: ["episodes", "filter", str(w.ds()), "--where", "success AND", "--out", str(w.root / "f")],
        r"--where",
        ("f",),
    ),
    (
        "filter-where-two-statements",
        lambda w: ["episodes", "filter", str(w.ds()), "--where", "1); SELECT (1", "--out", str(w.root / "f")],
        r"--where",
        ("f",),
    ),
    (
        "split-fractions-not-one",
        lambda w: ["episodes", "split", str(w.ds()), "--fractions", "0.5,0.4", "--out-dir", str(w.root / "p")],
        r"--fractions",
        ("p",),
    ),
    (
        "split-fractions-unsafe-name",
        lambda w: [
            *("episodes", "split", str(w.ds()), "--fractions", "0.5,0.5", "--names", "a,..", "--out-dir"),
            str(w.root / "p"),
        ],
        r"--names",
        ("p",),
    ),
    (
        "tasks-rename-unknown-task",
        lambda w: ["tasks", "rename", str(w.ds()), "--from", "no such task", "--to", "x", "--out", str(w.root / "t")],
        r"--from: .* has no task 'no such task'",
        ("t",),
    ),
    (
        "tasks-rename-empty-text",
        lambda w: ["tasks", "rename", str(w.ds()), "--from", "pick up the mock cube", "--to", " ", "--in-place"],
        r"--to: empty task text",
        (),
    ),
    (
        "tasks-set-empty-text",
        lambda w: ["tasks", "set", str(w.ds()), "--episodes", "0", "--task", "", "--out", str(w.root / "t")],
        r"--task: empty task text",
        ("t",),
    ),
    (
        "features-remove-unknown",
        lambda w: ["features", "remove", str(w.ds()), "--feature", "observation.nope", "--out", str(w.root / "f")],
        r"--feature: .* has no feature 'observation\.nope'",
        ("f",),
    ),
    (
        "features-remove-required",
        lambda w: ["features", "remove", str(w.ds()), "--feature", "frame_index", "--in-place"],
        r"--feature: frame_index is a column every LeRobot v3 dataset has",
        (),
    ),
    (
        "features-remove-state",
        lambda w: ["features", "remove", str(w.ds()), "--feature", "observation.state", "--out", str(w.root / "f")],
        r"--feature: observation\.state cannot be removed",
        ("f",),
    ),
    ("stats-recompute-no-output", lambda w: ["stats", "recompute", str(w.ds())], r"--out: give either", ()),
    (
        "stats-recompute-missing",
        lambda w: ["stats", "recompute", str(w.root / "gone"), "--out", str(w.root / "s")],
        r"gone",
        ("s", "gone"),
    ),
    ("info-path-is-a-file", lambda w: ["info", str(w.write("afile", "x"))], r"afile", ()),
    ("info-path-missing", lambda w: ["info", str(w.root / "nothing")], r"nothing", ()),
]
for _id, _argv, _names, _new in OPTIONS:
    _argv_case(_id, _argv, _names, _new)


# ---------------------------------------------------------------------------------------------------------------
# Outputs: a file where a folder is expected, a folder below a file, a folder where a file is expected

OUTPUTS: dict[str, tuple[Callable[[Workspace, str], list[str]], str]] = {
    "record": (lambda w, o: ["record", "--max-steps", "3", "--out", o], "--out"),
    "convert-bag": (lambda w, o: ["convert", str(w.bag), o], "DST"),
    "convert-dataset": (lambda w, o: ["convert", str(w.ds()), o], "DST"),
    "delete": (lambda w, o: ["episodes", "delete", str(w.ds()), "--episodes", "0", "--out", o], "--out"),
    "split-out": (lambda w, o: ["episodes", "split", str(w.ds()), "--episodes", "0", "--out", o], "--out"),
    "split-rest": (
        lambda w, o: ["episodes", "split", str(w.ds()), "--episodes", "0", "--out", str(w.root / "a"), "--rest", o],
        "--rest",
    ),
    "merge": (lambda w, o: ["episodes", "merge", str(w.ds()), str(w.ds("ds2")), "--out", o], "--out"),
    "filter": (lambda w, o: ["episodes", "filter", str(w.ds()), "--where", "true", "--out", o], "--out"),
    "split-fractions": (
        lambda w, o: ["episodes", "split", str(w.ds()), "--fractions", "0.5,0.5", "--out-dir", o],
        "--out-dir",
    ),
    "videos-reencode": (lambda w, o: ["videos", "reencode", str(w.ds()), "--codec", "h264", "--out", o], "--out"),
    "videos-encode-images": (lambda w, o: ["videos", "encode-images", str(w.ds()), "--out", o], "--out"),
    "replay-out": (lambda w, o: ["replay", str(w.ds()), "--out", o], "--out"),
    "replay-record": (lambda w, o: ["replay", str(w.ds()), "--out", str(w.root / "res"), "--record", o], "--record"),
    "pipeline-workdir": (
        lambda w, o: ["pipeline", "run", str(w.yaml("p.yaml", _pipeline(w))), "--workdir", o],
        "--workdir",
    ),
}


def _output_case(cmd: str, kind: str) -> None:
    argv, _option = OUTPUTS[cmd]

    def build(w: Workspace) -> list[str]:
        if kind == "is-a-file":
            target = w.write("taken", "precious")
        elif kind == "below-a-file":
            target = w.write("taken", "precious") / "sub"
        else:  # "not-empty"
            w.write("taken/notes.txt", "precious")
            target = w.root / "taken"
        return argv(w, str(target))

    case(f"{cmd}-output-{kind}", build, r"taken", ("a", "res") if cmd in ("split-rest", "replay-record") else ())


for _cmd in OUTPUTS:
    for _kind in ("is-a-file", "below-a-file", "not-empty"):
        # a pipeline resumes in its existing workdir; split --fractions writes new parts into an existing --out-dir
        if (_cmd, _kind) not in (("pipeline-workdir", "not-empty"), ("split-fractions", "not-empty")):
            _output_case(_cmd, _kind)

SAVES: list[tuple[str, Callable[[Workspace], list[str]], str]] = [
    ("view-save-is-a-folder", lambda w: ["view", str(w.ds()), "--save", str(w.path("taken/x").parent)], r"taken"),
    (
        "view-save-below-a-file",
        lambda w: ["view", str(w.ds()), "--save", str(w.write("taken", "x") / "v.rrd")],
        r"taken",
    ),
    ("stats-plot-is-a-folder", lambda w: ["stats", str(w.ds()), "--plot", str(w.path("taken/x").parent)], r"taken"),
    (
        "stats-plot-below-a-file",
        lambda w: ["stats", str(w.ds()), "--plot", str(w.write("taken", "x") / "p.png")],
        r"taken",
    ),
]
for _id, _argv, _names in SAVES:
    _argv_case(_id, _argv, _names)


# ---------------------------------------------------------------------------------------------------------------
# Bags: garbage, empty, truncated, wrong containers


def _bag_case(id: str, make: Callable[[Workspace], Path], names: str, mapping: bool = True) -> None:
    def build(w: Workspace) -> list[str]:
        src = make(w)
        extra = ["--mapping", str(w.yaml("m.yaml", MAPPING))] if mapping else []
        return ["convert", str(src), str(w.root / "o"), "--codec", "h264", *extra]

    case(id, build, names, ("o",))


def _flip_bag(w: Workspace, at: float) -> Path:
    data = bytearray(w.bag.read_bytes())
    for k in range(64):  # a run of flipped bytes inside the message data
        data[int(len(data) * at) + k] ^= 0x5A
    return w.write("flip.mcap", bytes(data))


def _cut_bag(w: Workspace, keep: float) -> Path:
    data = w.bag.read_bytes()
    return w.write("cut.mcap", data[: int(len(data) * keep)])


for _with in (True, False):
    _m = "" if _with else "-own-mapping"
    _bag_case(f"bag-mcap-empty{_m}", lambda w: w.write("e.mcap", b""), r"e\.mcap", _with)
    _bag_case(f"bag-mcap-garbage{_m}", lambda w: w.write("g.mcap", b"\x89MCAP0\r\n" + b"x" * 500), r"g\.mcap", _with)
    _bag_case(f"bag-mcap-truncated-10{_m}", lambda w: _cut_bag(w, 0.1), r"cut\.mcap", _with)
    _bag_case(f"bag-mcap-truncated-90{_m}", lambda w: _cut_bag(w, 0.9), r"cut\.mcap", _with)
    _bag_case(f"bag-ros1-empty{_m}", lambda w: w.write("e.bag", b""), r"e\.bag", _with)
    _bag_case(f"bag-ros1-garbage{_m}", lambda w: w.write("g.bag", b"#ROSBAG V2.0\n" + b"\x00" * 300), r"g\.bag", _with)
    _bag_case(
        f"bag-ros2-metadata-garbage{_m}",
        lambda w: w.write("r2/metadata.yaml", "rosbag2_bagfile_information: 3").parent,
        r"r2",
        _with,
    )
    _bag_case(
        f"bag-ros2-metadata-not-utf8{_m}", lambda w: w.write("r2/metadata.yaml", b"\xff\xfe").parent, r"r2", _with
    )
    _bag_case(f"bag-folder-without-bags{_m}", lambda w: w.write("plain/readme.txt", "hi").parent, r"plain", _with)
    _bag_case(f"bag-mcap-is-a-folder{_m}", lambda w: w.path("d.mcap/x").parent, r"d\.mcap", _with)
    _bag_case(f"bag-mcap-flipped-20{_m}", lambda w: _flip_bag(w, 0.2), r"flip\.mcap", _with)
    _bag_case(f"bag-mcap-flipped-80{_m}", lambda w: _flip_bag(w, 0.8), r"flip\.mcap", _with)


# ---------------------------------------------------------------------------------------------------------------
# doctor --repair on something that is not a dataset folder: one line, and no lock (not even .openral/) is created


def _repair_file(w: Workspace) -> list[str]:
    w.write("notes.txt", "not a dataset")
    return ["doctor", str(w.root / "notes.txt"), "--repair"]


_argv_case("doctor-repair-file", _repair_file, r"notes\.txt")
_argv_case("doctor-repair-missing", lambda w: ["doctor", str(w.root / "gone"), "--repair"], r"gone", ("gone",))


# ---------------------------------------------------------------------------------------------------------------
# convert: a part of a state or action that the bag cannot give (one line naming the bag, the part, its topic)


def _parts_case(id: str, part: dict[str, Any], names: str) -> None:
    def build(w: Workspace) -> list[str]:
        state = {"parts": [MAPPING["state"], part]}
        mapping = w.yaml("m.yaml", {**MAPPING, "state": state})
        return ["convert", str(w.bag), str(w.root / "o"), "--codec", "h264", "--mapping", str(mapping)]

    case(id, build, names, ("o",))


_parts_case(
    "mapping-part-missing-topic", {"topic": "/gripper"}, r"log\.mcap: mapped topic\(s\) /gripper not in the bag"
)
_parts_case(
    "mapping-part-not-numbers",
    {"topic": "/joint_states", "field": "name", "names": ["n"]},
    r"log\.mcap: mapping: state\.parts\[1\] \(/joint_states\.name\): field is list, not numbers",
)
_parts_case(
    "mapping-part-empty-field",
    {"topic": "/joint_states", "field": "velocity", "names": ["v"]},
    r"log\.mcap: mapping: state\.parts\[1\] \(/joint_states\.velocity\): the field is empty",
)
