"""Mistakes get one helpful line: "did you mean" for a misspelt id, "no such folder" for a missing local path."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.support.home import isolated_home
from tests.support.inproc import run_inproc
from tests.support.recorded import record_small


@pytest.fixture(scope="module")
def dataset(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return record_small(tmp_path_factory.mktemp("mistakes"))


def _error(*args: str) -> str:
    run = run_inproc(*args)
    assert run.returncode == 2, (run.stdout, run.stderr)
    assert run.stderr.count("\n") == 1 and run.stderr.startswith("error: "), run.stderr
    return run.stderr.strip()


CODECS = "'av1', 'h264', 'hevc', 'auto'"


@pytest.mark.parametrize(
    ("option", "typo", "meant", "listing"),
    [
        ("--scene", "tabletop_psh", "tabletop_push", "list scenes"),
        ("--rskill", "scripted-psh", "scripted-push", "list rskills"),
        ("--robot", "ur5", "ur5e", "list robots"),
    ],
)
def test_a_misspelt_id_gets_did_you_mean_on_one_short_line(
    tmp_path: Path, option: str, typo: str, meant: str, listing: str
) -> None:
    line = _error("record", option, typo, "--out", str(tmp_path / "o"))
    assert f"did you mean {meant!r}?" in line
    assert line.endswith(f"in all: openral-data {listing})")
    assert len(line) < 140  # never the whole list of ids
    assert not (tmp_path / "o").exists()


def test_an_unrelated_id_lists_a_dozen_and_points_at_list(tmp_path: Path) -> None:
    line = _error("record", "--scene", "zzzzzz", "--out", str(tmp_path / "o"))
    assert "valid: " in line and line.endswith("in all: openral-data list scenes)")
    assert line.count(",") <= 12


def test_a_misspelt_task_and_feature_get_did_you_mean(tmp_path: Path, dataset: Path) -> None:
    line = _error("record", "--scene", "robosuite_lift", "--task", "Lfit", "--out", str(tmp_path / "o"))
    assert "did you mean 'Lift'?" in line
    line = _error("features", "remove", str(dataset), "--feature", "observation.stat", "--out", str(tmp_path / "f"))
    assert "did you mean 'observation.state'?" in line


def test_a_misspelt_subcommand_gets_did_you_mean() -> None:
    assert "Did you mean 'info'?" in _error("infoo", "x")
    assert "Did you mean 'delete'?" in _error("episodes", "delet", "x")


@pytest.mark.parametrize("given", ["./nope", "nope", "/no/such/dataset", "a/b/c"])
def test_a_missing_local_path_says_no_such_folder_without_hub_advice(given: str, tmp_path: Path) -> None:
    with isolated_home(tmp_path):
        line = _error("info", given)
    assert line == f"error: {Path(given)}: no such file or directory"  # the path as typer gives it


def test_a_missing_child_of_a_local_folder_says_no_such_folder_first(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    (tmp_path / "datasets").mkdir()
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("HF_LEROBOT_HOME", str(tmp_path / "cache"))
    line = _error("info", "datasets/nope")
    assert line.startswith("error: datasets/nope: no such folder (")
    assert "add --download" not in line


def test_the_rskills_suggested_can_run_on_that_scene(tmp_path: Path) -> None:
    line = _error("record", "--scene", "mock_pick", "--robot", "ur5e", "--out", str(tmp_path / "o"))
    suggested = line.split("(rSkills that fit: ", 1)[1].rstrip(")").split(", ")
    assert "sweep-ur5e" in suggested
    assert "scripted-push" not in suggested  # a tabletop expert: no ground truth in a mock scene
    assert "lerobot-act-push" not in suggested  # neural, and its checkpoint folder is not there
    line = _error("record", "--scene", "tabletop_push", "--robot", "ur5e", "--rskill", "random-mock", "--out", "o")
    assert "scripted-push" in line and "lerobot-act-push" not in line


@pytest.mark.parametrize(
    ("args", "line"),
    [
        (
            ["record", "--codec", "h265x", "--out", "o"],
            "error: --vcodec: 'h265x' is not one of 'av1', 'h264', 'hevc', 'auto'",
        ),
        (
            ["videos", "reencode", "D", "--codec", "h26"],
            "error: --vcodec: 'h26' is not one of 'av1', 'h264', 'hevc', 'auto'",
        ),
        (["record", "--n-episodes", "x"], "error: --n-episodes: Input should be a valid integer, unable to parse"),
    ],
)
def test_a_value_pydantic_refuses_is_one_house_line(args: list[str], line: str) -> None:
    got = _error(*args)
    assert got.startswith(line), got
    assert "Value error" not in got and "Invalid value for" not in got
