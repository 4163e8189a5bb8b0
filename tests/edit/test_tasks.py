"""`tasks list|rename|set`: the frames' task_index, meta/tasks.parquet and the episodes' `tasks` follow; unused
tasks disappear, indices stay dense, a rename onto an existing task merges them; the results are healthy and load
in lerobot 0.6.1 with the new tasks and otherwise the source's frames; the source is unchanged."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pyarrow.parquet as pq
import pytest

from openral_data.doctor import check
from openral_data.edit import tasks
from openral_data.errors import DatasetBusy
from openral_data.formats.lerobot_v3.lock import DatasetLock
from tests.cli.test_json import check_object, parse
from tests.support.cli import run_cli
from tests.support.lerobot_written import LENGTHS, digest, loaded_episodes, same_frames, write_lerobot_dataset
from tests.support.seeded import verify_seeded_dataset


@pytest.fixture(scope="module")
def source(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("tasks") / "lerobot"
    write_lerobot_dataset(root, with_success=False, image_camera=True, environment_state=True)
    return root


def _task_table(root: Path) -> list[tuple[int, str]]:
    t = pq.read_table(root / "meta/tasks.parquet").to_pydict()
    return list(zip(t["task_index"], t["task"], strict=True))


def _listed(root: Path) -> list[dict[str, object]]:
    res = run_cli("tasks", "list", str(root), "--json")
    assert res.returncode == 0, res.stderr
    doc = parse(res.stdout, "tasks list")  # the fields docs/scripting.md lists, in order, of their types
    assert doc["command"] == "tasks list" and doc["dataset"] == str(root)
    for item in doc["tasks"]:
        check_object(item, "tasks list item")
    tasks_: list[dict[str, object]] = doc["tasks"]
    return tasks_


def test_set_then_rename_onto_an_existing_task_merges(source: Path, tmp_path: Path) -> None:
    before = digest(source)
    want = loaded_episodes(source)
    assert _listed(source) == [{"task_index": 0, "task": "push the block", "episodes": [0, 1, 2]}]
    one = tmp_path / "one"
    res = run_cli("tasks", "set", str(source), "--episodes", "1-2", "--task", "stack the cube", "--out", str(one))
    assert res.returncode == 0, res.stderr
    assert res.stdout.startswith(f"set: {one}  episodes 3  frames {sum(LENGTHS)}")
    assert _task_table(one) == [(0, "push the block"), (1, "stack the cube")]
    assert _listed(one) == [
        {"task_index": 0, "task": "push the block", "episodes": [0]},
        {"task_index": 1, "task": "stack the cube", "episodes": [1, 2]},
    ]
    assert [r["tasks"] for r in pq.read_table(one / "meta/episodes").to_pylist()] == [
        ["push the block"],
        ["stack the cube"],
        ["stack the cube"],
    ]
    got = loaded_episodes(one)
    for e, (g, w) in enumerate(zip(got, want, strict=True)):
        assert {f["task"] for f in g} == {"push the block" if e == 0 else "stack the cube"}
        same_frames(g, [dict(f, task=g[0]["task"]) for f in w])  # everything else is the source's
    assert check(one, deep=True) == []

    # episode 0's task renamed onto episode 1's: the two merge, the unused index disappears
    two = tmp_path / "two"
    tasks.rename(one, "push the block", "stack the cube", two)
    assert _task_table(two) == [(0, "stack the cube")]
    assert {f["task"] for e in loaded_episodes(two) for f in e} == {"stack the cube"}
    data = pq.read_table(two / "data").column("task_index").to_pylist()
    assert data == [0] * sum(LENGTHS)
    assert json.loads((two / "meta/info.json").read_text())["total_tasks"] == 1
    assert check(two, deep=True) == []
    assert digest(source) == before


def test_rename_in_place_of_our_dataset(project: Path, tmp_path: Path) -> None:
    from tests.edit.test_edit import _record

    ds = _record(project, tmp_path / "ours", 0, 3)
    [(_, old)] = _task_table(ds)
    res = run_cli("tasks", "rename", str(ds), "--from", old, "--to", "pick the red cube", "--in-place")
    assert res.returncode == 0, res.stderr
    assert _task_table(ds) == [(0, "pick the red cube")]
    assert check(ds, deep=True) == []
    verify_seeded_dataset(ds)  # every episode still holds exactly its own frames
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]  # no staging or replaced folder left


@pytest.mark.parametrize(
    ("args", "first_line"),
    [
        (["rename", "--from", "nope", "--to", "x"], "error: --from: {src} has no task 'nope' (its tasks: "),
        (["rename", "--from", "push the block", "--to", "  "], "error: --to: empty task text"),
        (["set", "--episodes", "7", "--task", "x"], "error: --episodes: '7' is outside"),
        (["set", "--episodes", "0", "--task", ""], "error: --task: empty task text"),
        (["set", "--episodes", "0", "--task", "x"], "error: --out: give either --out DIR or --in-place"),
    ],
)
def test_refusals_are_one_line_and_write_nothing(
    source: Path, tmp_path: Path, args: list[str], first_line: str
) -> None:
    before = digest(source)
    out = [] if args[-1] == "x" and args[0] == "set" and args[2] == "0" else ["--out", str(tmp_path / "o")]
    res = run_cli("tasks", args[0], str(source), *args[1:], *out)
    assert res.returncode == 2 and res.stderr.count("\n") == 1, res.stderr
    assert res.stderr.startswith(first_line.format(src=source)), res.stderr
    assert not (tmp_path / "o").exists() and digest(source) == before


def test_a_busy_dataset_is_refused(source: Path, tmp_path: Path) -> None:
    busy = shutil.copytree(source, tmp_path / "busy")
    with DatasetLock(busy, "record"), pytest.raises(DatasetBusy):
        tasks.set_task(busy, "0", "x", tmp_path / "o")
    assert not (tmp_path / "o").exists()
