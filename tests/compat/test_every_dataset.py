"""#30's acceptance matrix: every command on every LeRobot layout lerobot writes or wrote (tests/compat/sources.py).

Each source is built once per worker; every test works on its own copy, and the source must stay byte-identical.
Outputs are loaded by lerobot 0.6.1 and compared frame for frame (pixels equal) with the source's frames."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from tests.compat.sources import KINDS, LEGACY, build, source_frames
from tests.support.inproc import run_inproc
from tests.support.lerobot_written import IMAGE_CAMERA, Frame, digest, loaded_episodes, same_frames

pytestmark = pytest.mark.slow


@pytest.fixture(scope="session", params=KINDS)
def built(request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory) -> tuple[str, Path]:
    kind = str(request.param)
    return kind, build(kind, tmp_path_factory.mktemp(kind) / "source")


@pytest.fixture
def source(built: tuple[str, Path], tmp_path: Path) -> tuple[str, Path]:
    kind, root = built
    copy = tmp_path / "source"
    shutil.copytree(root, copy)
    return kind, copy


def ok(*args: str) -> str:
    run = run_inproc(*args)
    assert run.returncode == 0, (args, run.stdout[-2000:], run.stderr[-2000:])
    return run.stdout


def same_episodes(got: list[list[Frame]], want: list[list[Frame]]) -> None:
    assert len(got) == len(want)
    for g, w in zip(got, want, strict=True):
        same_frames(g, w)


def without(frames: list[list[Frame]], key: str) -> list[list[Frame]]:
    return [[{**f, key: None} for f in episode] for episode in frames]


def test_read_only_commands(source: tuple[str, Path], tmp_path: Path) -> None:
    kind, root = source
    before = digest(root)
    want = source_frames(kind, root)
    summary = json.loads(ok("info", str(root), "--json"))
    assert (summary["episodes"], summary["frames"]) == (len(want), sum(map(len, want)))
    assert summary["tasks"] == list(dict.fromkeys(f["task"] for e in want for f in e))  # task_index: first seen
    ok("doctor", str(root), "--deep")
    ok("stats", str(root))
    assert ok("stats", str(root), "--sql", "SELECT count(*) AS n FROM frames", "--format", "csv").split()[-1] == str(
        sum(map(len, want))
    )
    listed = ok("tasks", "list", str(root), "--json")
    assert {t["task"] for t in json.loads(listed)["tasks"]} == {f["task"] for e in want for f in e}
    ok("view", str(root), "--episode", "1", "--save", str(tmp_path / "e1.rrd"))
    assert (tmp_path / "e1.rrd").stat().st_size > 0
    ok("replay", str(root), "--mode", "policy", "--rskill", "recorded", "--out", str(tmp_path / "eval"))
    assert digest(root) == before


def test_mcap_and_back(source: tuple[str, Path], tmp_path: Path) -> None:
    kind, root = source
    ok("convert", str(root), str(tmp_path / "bag.mcap"))
    ok("convert", str(tmp_path / "bag.mcap"), str(tmp_path / "back"), "--codec", "h264")  # AV1 needs >= 32x32
    got = loaded_episodes(tmp_path / "back")
    assert [[f["state"] for f in e] for e in got] == [[f["state"] for f in e] for e in source_frames(kind, root)]


def test_edits(source: tuple[str, Path], tmp_path: Path) -> None:
    kind, root = source
    want = source_frames(kind, root)
    ok("episodes", "delete", str(root), "--episodes", "1", "--out", str(tmp_path / "deleted"))
    same_episodes(loaded_episodes(tmp_path / "deleted"), [want[0], want[2]])
    ok("features", "remove", str(root), "--feature", IMAGE_CAMERA, "--out", str(tmp_path / "removed"))
    same_episodes(loaded_episodes(tmp_path / "removed"), without(want, "wrist"))
    ok(
        "episodes",
        "split",
        str(root),
        "--episodes",
        "0",
        "--out",
        str(tmp_path / "first"),
        "--rest",
        str(tmp_path / "rest"),
    )
    same_episodes(loaded_episodes(tmp_path / "rest"), want[1:])
    ok("episodes", "merge", str(root), str(tmp_path / "first"), "--out", str(tmp_path / "merged"))
    same_episodes(loaded_episodes(tmp_path / "merged"), [*want, want[0]])
    ok(
        "tasks",
        "rename",
        str(root),
        "--from",
        want[0][0]["task"],
        "--to",
        "nudge it",
        "--out",
        str(tmp_path / "renamed"),
    )
    renamed = loaded_episodes(tmp_path / "renamed")
    assert {f["task"] for f in renamed[0]} == {"nudge it"}
    ok("stats", "recompute", str(root), "--out", str(tmp_path / "recomputed"))
    same_episodes(loaded_episodes(tmp_path / "recomputed"), want)


def test_upgrade(source: tuple[str, Path], tmp_path: Path) -> None:
    kind, root = source
    before = digest(root)
    run = run_inproc("upgrade", str(root), str(tmp_path / "new"))
    assert digest(root) == before
    if kind not in LEGACY:
        assert (run.returncode, len(run.stderr.splitlines())) == (2, 1) and "already" in run.stderr, run
        assert not (tmp_path / "new").exists()
        return
    assert run.returncode == 0, run
    ok("doctor", str(tmp_path / "new"), "--deep")
    same_episodes(loaded_episodes(tmp_path / "new"), source_frames(kind, root))
