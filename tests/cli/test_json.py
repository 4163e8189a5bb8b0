"""`--json` on info, doctor, convert, record and replay: the real CLI's stdout is exactly one JSON document whose
keys, key order and value types are the ones docs/scripting.md's field tables list (parsed here, so the docs and
the output cannot drift apart); its values agree with what was recorded; an error prints no JSON and exits 2."""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
import threading
from pathlib import Path
from typing import Any

import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from openral_data.version import __version__
from tests.support.cli import run_cli
from tests.support.home import REPO, isolated_home
from tests.support.scenes import mock_scene, write_yaml

DOC = REPO / "docs" / "scripting.md"
SUCCESS_AFTER = [3, 99]  # episode 0 succeeds at step 3, episode 1 never does (cut at MAX_STEPS)
MAX_STEPS = 6
TABLES = {
    "common", "info", "info bag", "info arrays", "doctor", "record", "record --hal", "convert bags-to-lerobot",
    "convert lerobot-to-mcap", "convert print-mapping",
    "replay", "list", "list item", "list scenes", "list rskills", "list robots", "list plugin_problems",
    "list tasks", "list tasks item", "tasks list", "tasks list item", "generate",
}  # fmt: skip


def field_tables() -> dict[str, list[tuple[str, str]]]:
    """docs/scripting.md's `<!-- json-fields: NAME -->` tables: NAME -> [(field, type)] in the documented order."""
    tables: dict[str, list[tuple[str, str]]] = {}
    current: list[tuple[str, str]] | None = None
    for line in DOC.read_text().splitlines():
        marker = re.fullmatch(r"<!-- json-fields: (.+) -->", line.strip())
        if marker:
            current = tables.setdefault(marker.group(1), [])
        elif current is not None and line.startswith("| `"):
            cells = [c.strip() for c in re.split(r"(?<!\\)\|", line)[1:-1]]
            current.append((cells[0].strip("`"), cells[1]))
        elif current is not None and not line.startswith("|"):
            current = None
    return tables


KINDS: dict[str, tuple[type, ...]] = {"str": (str,), "int": (int,), "float": (int, float), "bool": (bool,),
                                      "object": (dict,)}  # fmt: skip


def base_type(typ: str) -> str:
    """`list[int] or null` -> `int`."""
    typ = typ.removesuffix(" or null")
    return base_type(typ[5:-1]) if typ.startswith("list[") and typ.endswith("]") else typ


def matches(value: object, typ: str) -> bool:
    """`value` (parsed JSON) is of the documented type `typ`."""
    if typ.endswith(" or null"):
        return value is None or matches(value, typ.removesuffix(" or null"))
    if typ.startswith("list[") and typ.endswith("]"):
        return isinstance(value, list) and all(matches(v, typ[5:-1]) for v in value)
    exact = typ in ("bool", "object", "str")
    return isinstance(value, KINDS[typ]) and (exact or not isinstance(value, bool))  # JSON true is no number


def check_object(value: dict[str, Any], table: str, *extra: str) -> None:
    """`value` has exactly the fields of `table` (+ `extra` tables), in order, of their documented types."""
    tables = field_tables()
    fields = [f for name in (table, *extra) for f in tables[name]]
    assert list(value) == [name for name, _ in fields], (table, list(value))
    bad = {name: (value[name], typ) for name, typ in fields if not matches(value[name], typ)}
    assert not bad, (table, bad)


def parse(stdout: str, table: str) -> dict[str, Any]:
    """The one JSON line on stdout, checked against the common fields + `table`: keys, order, types."""
    lines = stdout.splitlines()
    assert len(lines) == 1, stdout  # one document, nothing else on stdout
    doc: dict[str, Any] = json.loads(lines[0])
    tables = field_tables()
    fields = tables["common"] + tables[table]
    assert list(doc) == [name for name, _ in fields], (table, list(doc))
    bad = {name: (doc[name], typ) for name, typ in fields if not matches(doc[name], typ)}
    assert not bad, (table, bad)
    assert doc["version"] == __version__
    return doc


def test_the_docs_have_every_table_and_known_types() -> None:
    tables = field_tables()
    assert set(tables) == TABLES
    for name, fields in tables.items():
        assert fields, name
        assert len({f for f, _ in fields}) == len(fields), name  # no field listed twice
        unknown = [(f, typ) for f, typ in fields if base_type(typ) not in KINDS]
        assert not unknown, (name, unknown)


@pytest.fixture(scope="module")
def recorded(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, str, str]:
    """`record --json` of 2 mock episodes (LeRobot + MCAP) with stderr on a terminal, where a progress bar would be
    drawn without --json: (dataset, stdout, what the terminal showed)."""
    base = tmp_path_factory.mktemp("json")
    scene = write_yaml(base / "scene.yaml", mock_scene(success_after=SUCCESS_AFTER, n_episodes=2, max_steps=MAX_STEPS))
    out = base / "ds"
    master, slave = os.openpty()
    shown: list[bytes] = []
    reader = threading.Thread(target=_drain, args=(master, shown))
    reader.start()
    args = ["record", "--scene", str(scene), "--out", str(out), "--codec", "h264", "--format", "lerobot,mcap"]
    with isolated_home(base):
        done = subprocess.run(
            [sys.executable, "-m", "openral_data.cli", *args, "--json"],
            stdout=subprocess.PIPE,
            stderr=slave,
            text=True,
            env={**os.environ, "COLUMNS": "120", "TERM": "xterm"},
            timeout=600,
            check=False,
        )
    os.close(slave)
    reader.join(timeout=10)
    os.close(master)
    terminal = b"".join(shown).decode(errors="replace")
    assert done.returncode == 0, terminal
    return out, done.stdout, terminal


def _drain(fd: int, into: list[bytes]) -> None:
    while True:
        try:
            chunk = os.read(fd, 4096)
        except OSError:  # the other side closed
            return
        if not chunk:
            return
        into.append(chunk)


def test_record(recorded: tuple[Path, str, str]) -> None:
    out, stdout, terminal = recorded
    doc = parse(stdout, "record")
    assert "recording" not in terminal and "━" not in terminal  # --json: no progress bar, even on a terminal
    assert "{" not in terminal  # and the document went to stdout only
    assert doc["command"] == "record" and doc["out"] == str(out)
    assert doc["episodes"] == 2 and doc["successes"] == 1 and doc["success_rate"] == 0.5
    assert [e["success"] for e in doc["episode_list"]] == [True, False]
    assert [e["length"] for e in doc["episode_list"]] == [3, MAX_STEPS]
    assert doc["frames"] == 3 + MAX_STEPS
    assert doc["formats"] == ["lerobot", "mcap"] and doc["mcap_dir"] == str(out / "mcap")
    assert doc["codec"] == "h264" and doc["resumed_at"] == 0 and doc["workers"] == 1 and doc["executor"] is None


def test_info(recorded: tuple[Path, str, str]) -> None:
    out, _, _ = recorded
    done = run_cli("info", str(out), "--json")
    assert done.returncode == 0, done.stderr
    doc = parse(done.stdout, "info")
    assert doc["command"] == "info" and doc["path"] == str(out)
    assert (doc["episodes"], doc["frames"], doc["fps"]) == (2, 3 + MAX_STEPS, 20)
    assert doc["duration_s"] == pytest.approx((3 + MAX_STEPS) / 20)
    assert doc["cameras"] == ["observation.images.front", "observation.images.wrist"]
    assert doc["tasks"] == ["pick up the mock cube"] and doc["robot_type"] == "mock_arm"
    assert (doc["success_known"], doc["successes"], doc["success_rate"]) == (True, 1, 0.5)


def test_doctor_healthy_damaged_and_repaired(recorded: tuple[Path, str, str], tmp_path: Path) -> None:
    out, _, _ = recorded
    done = run_cli("doctor", str(out), "--json")
    assert done.returncode == 0, done.stderr
    doc = parse(done.stdout, "doctor")
    assert doc["healthy"] is True and doc["findings"] == [] and doc["exit_code"] == 0

    root = tmp_path / "ds"
    shutil.copytree(out, root, symlinks=True)
    episodes = root / "meta/episodes/chunk-000/file-000.parquet"  # its rows in reverse order
    table = pq.read_table(episodes)
    pq.write_table(table.take(pa.array(range(table.num_rows - 1, -1, -1))), episodes)

    damaged = run_cli("doctor", str(root), "--json")
    assert damaged.returncode == 1, damaged.stderr
    doc = parse(damaged.stdout, "doctor")
    assert doc["healthy"] is False and doc["exit_code"] == 1 and doc["errors"] >= 1
    finding = next(f for f in doc["findings"] if f["code"] == "episodes.order")
    assert finding["severity"] == "error" and finding["repairable"] is True
    assert set(finding) == {"code", "severity", "where", "message", "repairable"}
    assert finding["where"] == "meta/episodes"

    fixed = run_cli("doctor", str(root), "--repair", "--json")
    doc = parse(fixed.stdout, "doctor")
    assert fixed.returncode == doc["exit_code"] == 0, fixed.stdout
    assert doc["repair"] is True and doc["repaired"] and doc["refused"] == [] and doc["healthy"] is True
    assert doc["quarantine"] is not None and Path(doc["quarantine"]).is_dir()


def test_convert_both_directions(recorded: tuple[Path, str, str], tmp_path: Path) -> None:
    out, _, _ = recorded
    exported = run_cli("convert", str(out), str(tmp_path / "bags"), "--episodes", "1", "--json")
    assert exported.returncode == 0, exported.stderr
    doc = parse(exported.stdout, "convert lerobot-to-mcap")
    assert doc["direction"] == "lerobot-to-mcap" and doc["out"] == str(tmp_path / "bags")
    assert doc["episodes"] == 1 and doc["frames"] == MAX_STEPS
    assert [e["index"] for e in doc["episode_list"]] == [1]

    converted = run_cli("convert", str(out / "mcap"), str(tmp_path / "back"), "--codec", "h264", "--json")
    assert converted.returncode == 0, converted.stderr
    doc = parse(converted.stdout, "convert bags-to-lerobot")
    assert doc["direction"] == "bags-to-lerobot" and doc["bags"] == 2
    assert (doc["episodes"], doc["frames"], doc["fps"]) == (2, 3 + MAX_STEPS, 20)
    assert doc["unfillable_frames"] == 0 and doc["late_messages"] is None
    assert all(t["messages"] == 3 + MAX_STEPS for t in doc["topics"].values()), doc["topics"]
    assert [e["success"] for e in doc["episode_list"]] == [True, False]


def test_replay_actions_and_policy(recorded: tuple[Path, str, str], tmp_path: Path, project: Path) -> None:
    out, _, _ = recorded
    done = run_cli("replay", str(out), "--out", str(tmp_path / "r1"), "--json")
    assert done.returncode == 0, done.stderr
    doc = parse(done.stdout, "replay")
    assert doc["mode"] == "actions" and doc["results"] == str(tmp_path / "r1") and doc["episodes"] == 2
    assert doc["reproduced"] == 2 and doc["diverged_episodes"] == {} and doc["divergence_max"] == 0.0
    assert (doc["success_recorded"], doc["success_replayed"], doc["success_agree"]) == (1, 1, 2)
    assert doc["steps_compared"] is None and doc["paired"] is None
    assert [e["steps"] for e in doc["episode_list"]] == [3, MAX_STEPS]
    assert json.loads((tmp_path / "r1" / "summary.json").read_text())["reproduced"] == 2

    done = run_cli(
        "replay", str(out), "--mode", "policy", "--rskill", "recorded", "--out", str(tmp_path / "r2"), "--json"
    )
    assert done.returncode == 0, done.stderr
    doc = parse(done.stdout, "replay")
    assert doc["mode"] == "policy" and doc["rskill"] == "recorded"
    assert doc["steps_compared"] == 3 + MAX_STEPS and doc["action_mae_mean"] == 0.0
    assert doc["success_replayed"] is None and doc["reproduced"] is None and doc["tolerance"] is None


@pytest.mark.slow  # a subprocess recording through the UR5e MuJoCo twin: ~5 s alone
def test_record_hal(tmp_path: Path, project: Path) -> None:
    done = run_cli(
        "record", "--hal", "ur5e", "--rskill", "sweep-ur5e", "--fps", "20", "--max-steps", "6",
        "--n-episodes", "2", "--operator", "success@4,discard@2", "--codec", "h264", "--out", str(tmp_path / "o"),
        "--json", env={"MUJOCO_GL": "egl"},
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    doc = parse(done.stdout, "record --hal")
    assert (doc["hal"], doc["mode"], doc["fps"]) == ("ur5e", "sim", 20)
    assert (doc["episodes"], doc["discarded"], doc["frames"]) == (2, 1, 4 + 6)
    assert [e["length"] for e in doc["episode_list"]] == [4, 6] and doc["estop"] is None


@pytest.mark.parametrize(
    "args",
    [
        ["info", "{tmp}/missing"],
        ["doctor", "{tmp}/missing", "--deep", "--repair", "--nope"],
        ["record", "--scene", "nope", "--out", "{tmp}/o"],
        ["replay", "{tmp}/missing"],
        ["convert", "{tmp}/missing", "{tmp}/dst"],
    ],
    ids=lambda a: a[0],
)
def test_an_error_prints_no_json(args: list[str], tmp_path: Path, project: Path) -> None:
    done = run_cli(*(a.format(tmp=tmp_path) for a in args), "--json")
    assert done.returncode == 2, (done.stdout, done.stderr)
    assert done.stdout == ""  # `jq` fails on it rather than reading half a document
    lines = done.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), done.stderr
    assert not (tmp_path / "o").exists() and not (tmp_path / "dst").exists()


def test_every_exit_status_the_cli_uses_is_documented() -> None:
    """The exit-code table lists each literal status `cli/` exits with (typer.Exit(N), sys.exit(N))."""
    text = DOC.read_text()
    table = text[text.index("<!-- exit-codes -->") :]
    documented = {int(m) for m in re.findall(r"^\| (\d+)", table, flags=re.M)}
    used = {0}  # a command that returns
    for path in (REPO / "openral_data" / "cli").glob("*.py"):
        used |= {int(m) for m in re.findall(r"(?:Exit|sys\.exit)\((\d+)\)", path.read_text())}
    assert used == documented, (sorted(used), sorted(documented))


def test_list(tmp_path: Path) -> None:
    done = run_cli("list", "--json", env={"OPENRAL_DATA_HOME": str(tmp_path)})
    assert done.returncode == 0, done.stderr
    doc = parse(done.stdout, "list")
    for section in ("scenes", "rskills", "robots", "scene_types", "policies"):
        own = (f"list {section}",) if section in ("scenes", "rskills", "robots") else ()
        for item in doc[section]:
            check_object(item, "list item", *own)
            assert item["origin"] == "built-in" and item["error"] is None and item["overrides"] == []
            assert (item["path"] is None) == (section in ("scene_types", "policies"))
    ids = {section: [it["id"] for it in doc[section]] for section in ("scenes", "rskills", "robots")}
    assert {"mock_pick", "tabletop_push", "robosuite_lift"} <= set(ids["scenes"]) and ids["scenes"] == sorted(
        ids["scenes"]
    )
    assert {"random-mock", "scripted-push"} <= set(ids["rskills"]) and "franka_panda" in ids["robots"]
    push = next(it for it in doc["scenes"] if it["id"] == "tabletop_push")
    assert (push["type"], push["robot"], push["default_rskill"]) == ("tabletop_push", "franka_panda", "scripted-push")
    assert {it["id"] for it in doc["scene_types"]} >= {"mock", "tabletop_push", "libero"}
    assert doc["plugin_problems"] == []  # their fields: tests/record/test_plugins.py


def test_list_one_section_an_override_and_a_broken_manifest(tmp_path: Path) -> None:
    (tmp_path / "rskills/random-mock").mkdir(parents=True)
    (tmp_path / "rskills/random-mock/rskill.yaml").write_text("id: random-mock\npolicy: [not, a, string]\n")
    done = run_cli("list", "rskills", "--json", env={"OPENRAL_DATA_HOME": str(tmp_path)})
    assert done.returncode == 0, done.stderr
    doc = parse(done.stdout, "list")
    assert doc["scenes"] is None and doc["robots"] is None and doc["policies"] is None
    item = next(it for it in doc["rskills"] if it["id"] == "random-mock")
    check_object(item, "list item", "list rskills")
    assert item["origin"] == "project" and item["overrides"] == ["built-in"]
    assert item["path"] == str(tmp_path / "rskills/random-mock/rskill.yaml")
    assert item["error"] is not None and "policy" in item["error"] and item["policy"] is None


def test_list_tasks() -> None:
    """`list tasks SCENE --json`: its own document (robosuite's tasks are declared without importing robosuite)."""
    done = run_cli("list", "tasks", "robosuite_lift", "--json")
    assert done.returncode == 0, done.stderr
    doc = parse(done.stdout, "list tasks")
    assert doc["command"] == "list" and doc["scene"] == "robosuite_lift"
    for item in doc["tasks"]:
        check_object(item, "list tasks item")
    assert [t["id"] for t in doc["tasks"]][:2] == ["Lift", "Stack"]
    assert doc["tasks"][0]["instruction"] == "lift the red cube off the table"
    refused = run_cli("list", "tasks", "pusht", "--json")
    assert refused.returncode == 2 and refused.stdout == ""
    assert "scene.type: 'gym_pusht' scenes have no tasks" in refused.stderr
