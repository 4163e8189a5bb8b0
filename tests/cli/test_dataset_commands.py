"""Every dataset command keeps what the docs promise (docs/hub.md#downloading-a-dataset---download,
docs/upgrade.md#other-commands-on-v2x-datasets): it takes `--download/--revision/--include` and a LeRobot v2.x
dataset. Then `episodes trim`/`resample` and `features rename`/`add` on a real v2.1 dataset written by lerobot
0.3.3's own writer (frame t of episode e has state [t, e, 0.5], action [0.1 t, -0.1 t]), and episode numbers
typed for a v2.1 dataset whose only episode is 29 (the real G1 fixture's shape) meaning that episode, and named
so in what replay and quality print."""

from __future__ import annotations

import json
import shutil
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow.parquet as pq
import pytest
import typer

from openral_data.cli.app import app
from openral_data.cli.takes import declared
from openral_data.episodes import renumber_list, select_numbered
from openral_data.errors import EpisodeSelectionError
from tests.support.inproc import run_inproc
from tests.support.lerobot_written import VIDEO_CAMERA, digest
from tests.support.old_lerobot import write_old
from tests.support.upgrade_cases import old_frames, renumber, subset

DOWNLOAD = {"--download", "--revision", "--include"}
# documented exceptions (docs/hub.md, docs/upgrade.md): push's --revision is the branch it pushes to and it refuses
# v2.x (upgrade first); generate's source is demonstrations recorded by openral-data in a MuJoCo scene
NOT_HUB_OR_V2 = {"push", "generate"}


def _commands(command: Any, path: tuple[str, ...] = ()) -> Iterator[tuple[str, Any]]:
    if hasattr(command, "commands"):
        for name, sub in command.commands.items():
            yield from _commands(sub, (*path, name))
    else:
        yield " ".join(path), command


def _takes_a_dataset(command: Any) -> bool:
    """An argument whose help names a dataset to read (not one to write)."""
    return any(
        p.param_type_name == "argument" and "dataset" in (p.help or "") and "must not exist" not in (p.help or "")
        for p in command.params
    )


def test_every_dataset_command_takes_v2_and_download() -> None:
    walked = dict(_commands(typer.main.get_command(app)))
    dataset_commands = {name for name, command in walked.items() if _takes_a_dataset(command)}
    assert {"info", "episodes trim", "features add", "stats report"} <= dataset_commands  # the walk sees them
    lacking = []
    for name in sorted(dataset_commands - NOT_HUB_OR_V2):
        command = walked[name]
        takes = declared(command.callback)
        options = {o for p in command.params for o in p.opts}
        if takes is None or takes.v2 not in ("in place", "upgrade") or not options >= DOWNLOAD:
            lacking.append(f"{name}: {takes}, options {sorted(DOWNLOAD & options)}")
    assert not lacking, "dataset commands without what the docs promise:\n" + "\n".join(lacking)
    for name in NOT_HUB_OR_V2:  # declared too, refusing v2.x in one line
        takes = declared(walked[name].callback)
        assert takes is not None and takes.v2 == "refused" and not takes.download, name


def test_episode_numbers_typed_in_a_v2_datasets_own_numbering() -> None:
    assert renumber_list("29,5-7", [5, 6, 7, 29]) == "3,0,1,2"
    assert renumber_list("0,2-1", [0, 1, 2]) == "0,2-1"  # numbered 0..n-1: as typed
    assert select_numbered("29", [29]) == [0]
    with pytest.raises(EpisodeSelectionError, match=r"'5-7': episode 6 is not one of the dataset's episodes 5,7,29"):
        select_numbered("5-7", [5, 7, 29])


@pytest.fixture(scope="module")
def v21(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Two episodes (12 and 8 frames, 10 fps) written by lerobot 0.3.3."""
    return write_old("0.3.3", tmp_path_factory.mktemp("v21") / "ds", lengths=[12, 8])


@pytest.fixture(scope="module")
def only_29(v21: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """That dataset's second episode alone, numbered 29 (its `index` starting at 12; info.json's totals right)."""
    root = shutil.copytree(v21, tmp_path_factory.mktemp("only29") / "ds")
    subset(root)
    info = json.loads((root / "meta/info.json").read_text())
    (root / "meta/info.json").write_text(json.dumps({**info, "total_episodes": 1, "total_frames": 8}, indent=4))
    return renumber(root, {1: 29})


def ok(*args: object) -> str:
    run = run_inproc(*map(str, args))
    assert run.returncode == 0, (args, run.stdout[-2000:], run.stderr[-2000:])
    return run.stdout


def frames(root: Path) -> list[list[dict[str, Any]]]:
    """A v3 dataset's rows per episode, by lerobot 0.6.1's loader."""
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    ds = LeRobotDataset("local/check", root=root, video_backend="pyav")
    out: list[list[dict[str, Any]]] = [[] for _ in range(ds.meta.total_episodes)]
    for i in range(len(ds)):
        item = ds[i]
        out[int(item["episode_index"])].append(item)
    return out


def states(root: Path) -> list[list[list[float]]]:
    return [[np.asarray(f["observation.state"]).tolist() for f in ep] for ep in frames(root)]


def state(t: int, e: int) -> list[float]:
    return [float(t), float(e), 0.5]


@pytest.mark.slow
def test_trim_and_resample_a_v21_dataset(v21: Path, tmp_path: Path) -> None:
    before = digest(v21)
    ok("episodes", "trim", v21, "--frames", "0:0-2,1:5-7", "--out", tmp_path / "trimmed")
    assert states(tmp_path / "trimmed") == [[state(t, 0) for t in range(3, 12)], [state(t, 1) for t in range(5)]]
    ok("episodes", "resample", v21, "--fps", "5", "--out", tmp_path / "resampled")
    assert states(tmp_path / "resampled") == [
        [state(t, 0) for t in range(0, 12, 2)],
        [state(t, 1) for t in (0, 2, 4, 6)],
    ]
    assert json.loads((tmp_path / "resampled/meta/info.json").read_text())["fps"] == 5
    assert digest(v21) == before


@pytest.mark.slow
def test_rename_and_add_features_of_a_v21_dataset(v21: Path, tmp_path: Path) -> None:
    front = "observation.images.front"
    ok("features", "rename", v21, "--from", VIDEO_CAMERA, "--to", front, "--out", tmp_path / "renamed")
    got, want = frames(tmp_path / "renamed"), old_frames(v21)
    assert VIDEO_CAMERA not in got[0][0]
    for g_ep, w_ep in zip(got, want, strict=True):
        assert [np.asarray(f[front]).tolist() for f in g_ep] == [w["cam"].tolist() for w in w_ep]  # packets moved
    rename = f"{v21}:{VIDEO_CAMERA}={front}"  # --rename names the v2.1 dataset as given, not its upgrade
    ok("episodes", "merge", v21, tmp_path / "renamed", "--rename", rename, "--out", tmp_path / "merged")
    assert states(tmp_path / "merged") == states(tmp_path / "renamed") * 2
    ok("features", "add", v21, "--name", "action.y", "--sql", "action[2]", "--out", tmp_path / "added")
    table = pq.read_table(sorted((tmp_path / "added/data").rglob("*.parquet"))[0])
    assert table.column("action.y").to_pylist() == [a[1] for a in table.column("action").to_pylist()]
    assert table.column("action.y").to_pylist()[:3] == pytest.approx([0.0, -0.1, -0.2])


@pytest.mark.slow
def test_episode_29_of_a_v21_dataset_is_addressed_as_29(only_29: Path, tmp_path: Path) -> None:
    ok("episodes", "trim", only_29, "--frames", "29:0-2", "--out", tmp_path / "trimmed")
    assert states(tmp_path / "trimmed") == [[state(t, 1) for t in range(3, 8)]]
    ok("tasks", "set", only_29, "--episodes", "29", "--task", "stack", "--out", tmp_path / "set")
    assert {f["task"] for f in frames(tmp_path / "set")[0]} == {"stack"}
    ok("episodes", "split", only_29, "--spec", "all=29", "--out-dir", tmp_path / "parts")
    assert states(tmp_path / "parts/all") == [[state(t, 1) for t in range(8)]]
    ok("convert", only_29, tmp_path / "bags", "--episodes", "29")  # read in place: the bag keeps its number
    assert [p.name for p in (tmp_path / "bags").iterdir()] == ["episode_000029"]
    doc = json.loads(
        ok(
            "replay",
            only_29,
            "--episodes",
            "29",
            "--mode",
            "policy",
            "--rskill",
            "recorded",
            "--out",
            tmp_path / "eval",
            "--json",
        )
    )
    assert [e["index"] for e in doc["episode_list"]] == [29] and doc["dataset"] == str(only_29)
    assert set(pq.read_table(tmp_path / "eval/steps.parquet").column("episode_index").to_pylist()) == {29}
    assert ok("quality", only_29, "--all", "--format", "csv").splitlines()[-1].startswith("ds,29,")
    run = run_inproc("episodes", "delete", str(only_29), "--episodes", "0", "--out", str(tmp_path / "none"))
    assert run.returncode == 2 and run.stderr.count("\n") == 1, run.stderr
    assert "'0': episode 0 is not one of the dataset's episodes 29" in run.stderr
    run = run_inproc("episodes", "trim", str(only_29), "--frames", "29:0-20", "--out", str(tmp_path / "none"))
    assert run.returncode == 2 and "openral-upgrade" not in run.stderr, run.stderr
    assert f"numbers {only_29}'s episodes 29 as 0..0" in run.stderr
