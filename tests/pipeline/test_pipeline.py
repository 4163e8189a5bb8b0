"""`pipeline run`: the shipped mock campaign end to end, killed mid-run and resumed; YAML errors are one line."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pyarrow.parquet as pq
import pytest

# ConfigError raises are matched by message on purpose: the file and field it names are the point
from openral_data.errors import ConfigError
from openral_data.pipeline.runner import run_pipeline
from openral_data.pipeline.schema import load_pipeline
from tests.support.cli import run_cli
from tests.support.crash import KILLED
from tests.support.home import REPO
from tests.support.scenes import write_yaml
from tests.support.timing import TIMED

pytestmark = TIMED

MOCK = REPO / "pipelines" / "mock_campaign.yaml"
STEPS = ["rec", "all", "replayed", "metrics", "bags"]


def _report(workdir: Path) -> dict[str, object]:
    data: dict[str, object] = json.loads((workdir / "report.json").read_text())
    return data


def _statuses(workdir: Path) -> list[tuple[str, str]]:
    return [(s["step"], s["status"]) for s in _report(workdir)["steps"]]  # type: ignore[attr-defined]


def test_every_shipped_pipeline_validates() -> None:
    files = sorted((REPO / "pipelines").glob("*.yaml"))
    assert MOCK in files and len(files) >= 2
    for f in files:
        load_pipeline(f)


def test_mock_campaign_end_to_end_killed_and_resumed(project: Path, tmp_path: Path) -> None:
    workdir = tmp_path / "run"
    # 1. kill the run, as SIGKILL would, right before the merge step renames its staged output into place: the
    #    record step is marked complete, the merged dataset is whole in its hidden staging folder
    #    (tests/support/cli_driver.py; waiting for the staging folder and killing from here raced a fast merge)
    driver = [sys.executable, "-m", "tests.support.cli_driver", "dataset", "1"]
    killed = subprocess.run(
        [*driver, "pipeline", "run", str(MOCK), "--workdir", str(workdir)],
        capture_output=True,
        env=os.environ.copy(),
        cwd=REPO,
        timeout=300,
        check=False,
    )
    assert killed.returncode == KILLED, killed.stderr
    assert list((workdir / "all").glob(".dataset.partial-*/**/*.parquet")), "the merge was staged"
    rec_marker = (workdir / "rec" / ".done.json").read_bytes()
    assert not (workdir / "report.json").exists()
    assert not (workdir / "all" / "dataset").exists()  # killed before the staging folder's rename

    # 2. resume: the record step is skipped (its outputs untouched), everything after it runs
    res = run_cli("pipeline", "run", str(MOCK), "--workdir", str(workdir))
    assert res.returncode == 0, res.stderr
    assert _statuses(workdir) == [("rec", "skipped")] + [(s, "ran") for s in STEPS[1:]]
    assert (workdir / "rec" / ".done.json").read_bytes() == rec_marker
    assert "rec (record): done earlier, skipped" in res.stderr

    # no staging folder of the killed run is left: only the completion markers are hidden
    for step in STEPS:
        hidden = [p.name for p in (workdir / step).iterdir() if p.name.startswith(".")]
        assert all(h == ".done.json" or h.endswith(".done") for h in hidden), (step, hidden)

    # outputs addressed by name: two recorded datasets, their merge, replay results, stats, bags
    recs = sorted(p.name for p in (workdir / "rec").iterdir() if not p.name.startswith("."))
    assert recs == ["mock_pick--random-mock", "mock_pick--zero-mock"]
    merged = workdir / "all" / "dataset"
    info = json.loads((merged / "meta" / "info.json").read_text())
    assert (info["total_episodes"], info["total_frames"]) == (4, 48)
    replayed = workdir / "replayed"
    for name in recs:
        summary = json.loads((replayed / name / "summary.json").read_text())
        assert summary["reproduced"] == 2, summary
        assert pq.read_table(replayed / name / "episodes.parquet").num_rows == 2
    stats = json.loads((workdir / "metrics" / "report" / "stats.json").read_text())
    assert {g["rskill"] for g in stats["groups"]} == {"random-mock", "zero-mock"}
    assert sorted(p.name for p in (workdir / "bags" / "dataset").glob("episode_*")) == [
        "episode_000000",
        "episode_000001",
    ]

    # 3. a complete run is skipped as a whole; a changed step is refused, not silently redone
    res = run_cli("pipeline", "run", str(MOCK), "--workdir", str(workdir))
    assert res.returncode == 0 and _statuses(workdir) == [(s, "skipped") for s in STEPS]
    changed = tmp_path / "changed.yaml"
    changed.write_text(MOCK.read_text().replace("count: 2", "count: 3"))
    res = run_cli("pipeline", "run", str(changed), "--workdir", str(workdir))
    assert res.returncode == 2 and res.stderr.startswith("error: step rec: its configuration changed")


def test_an_unmarked_item_is_redone(project: Path, tmp_path: Path) -> None:
    spec = write_yaml(
        tmp_path / "p.yaml",
        {
            "name": "small",
            "steps": [
                {"id": "rec", "record": {"scenes": ["mock_pick"], "rskills": ["zero-mock", "random-mock"],
                                         "seeds": {"count": 1}, "max_steps": 3, "codec": "h264"}},
            ],
        },
    )  # fmt: skip
    workdir = tmp_path / "run"
    run_pipeline(spec, workdir)
    # as if killed while writing the second item: its marker and the step marker are missing, the folder is junk
    (workdir / "rec" / ".done.json").unlink()
    (workdir / "rec" / ".mock_pick--random-mock.done").unlink()
    (workdir / "rec" / "mock_pick--random-mock" / "junk").write_text("half written")
    first = (workdir / "rec" / "mock_pick--zero-mock" / "meta" / "info.json").stat().st_mtime_ns
    lines: list[str] = []
    report = run_pipeline(spec, workdir, log=lines.append)
    assert "rec/mock_pick--zero-mock: done earlier, skipped" in lines
    assert "rec/mock_pick--random-mock: running" in lines
    assert not (workdir / "rec" / "mock_pick--random-mock" / "junk").exists()
    assert (workdir / "rec" / "mock_pick--zero-mock" / "meta" / "info.json").stat().st_mtime_ns == first
    assert report.steps[0]["summary"]["mock_pick--random-mock"]["episodes"] == 1


@pytest.mark.parametrize(
    ("steps", "message"),
    [
        ([{"id": "a", "merge": {"inputs": ["rec"]}}], r"steps\[0\]\.merge\.inputs\[0\]: 'rec' is not an earlier step"),
        ([{"id": "a", "stats": {"inputs": ["x"]}, "merge": {"inputs": ["x"]}}], "give exactly one of"),
        ([{"id": "a", "record": {"scenes": ["mock_pick"], "rskills": ["zero-mock"], "seeds": {"count": 1},
                                 "colour": "red"}}], r"steps\[0\]\.record\.colour: unknown key"),
        ([{"id": "r", "record": {"scenes": ["mock_pick"], "rskills": ["zero-mock"], "seeds": {"count": 1}}},
          {"id": "s", "stats": {"inputs": ["r"]}}, {"id": "x", "replay": {"dataset": "s"}}],
         r"steps\[2\]\.replay\.dataset: 's' is a stats step"),
        ([{"id": "r", "record": {"scenes": ["mock_pick"], "rskills": ["zero-mock"], "seeds": {"count": 0}}}],
         r"steps\[0\]\.record\.seeds\.count"),
    ],
)  # fmt: skip
def test_pipeline_yaml_errors_name_file_and_field(tmp_path: Path, steps: list[object], message: str) -> None:
    spec = write_yaml(tmp_path / "bad.yaml", {"name": "bad", "steps": steps})
    with pytest.raises(ConfigError, match=message) as err:
        load_pipeline(spec)
    assert str(err.value).startswith(str(spec)) and "\n" not in str(err.value)


def test_pipeline_cli_error_is_one_line(tmp_path: Path) -> None:
    spec = write_yaml(tmp_path / "bad.yaml", {"name": "bad", "steps": [{"id": "a", "merge": {"inputs": ["nope"]}}]})
    res = run_cli("pipeline", "run", str(spec), "--workdir", str(tmp_path / "w"))
    assert res.returncode == 2 and res.stderr.count("\n") == 1 and "'nope' is not an earlier step" in res.stderr
    assert not (tmp_path / "w").exists()


def test_record_step_sweeps_tasks_with_an_instruction_and_device(project: Path, tmp_path: Path) -> None:
    """`tasks:` sweeps `record --task` per scene (one dataset per task, `/` -> `-` in its name); `instruction` and
    `device` reach every recording."""
    pytest.importorskip("robosuite")
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    from openral_data.replay.recorded import RecordedDataset

    spec = write_yaml(
        tmp_path / "p.yaml",
        {
            "name": "tasks",
            "steps": [
                {"id": "rec", "record": {"scenes": ["robosuite_lift"], "rskills": ["robosuite-panda-random"],
                                         "tasks": ["Lift", "Stack"], "seeds": {"count": 1}, "max_steps": 2,
                                         "codec": "h264", "instruction": "move a little", "device": "auto"}},
            ],
        },
    )  # fmt: skip
    step = load_pipeline(spec).steps[0].record
    assert step is not None
    names = [name for name, *_ in step.items()]
    assert names == ["robosuite_lift--robosuite-panda-random--Lift", "robosuite_lift--robosuite-panda-random--Stack"]
    libero = step.model_copy(update={"tasks": ["libero_spatial/3"]})
    assert libero.items()[0][0] == "robosuite_lift--robosuite-panda-random--libero_spatial-3"
    workdir = tmp_path / "run"
    run_pipeline(spec, workdir)
    for name, env in zip(names, ("Lift", "Stack"), strict=True):
        out = workdir / "rec" / name
        options = json.loads((out / ".openral/record.json").read_text())["options"]
        assert options["task"] == env and options["instruction"] == "move a little"
        ds = LeRobotDataset("local/x", root=out, video_backend="pyav")
        assert RecordedDataset(out).scene().scene.params["env"] == env
        assert ds[0]["task"] == "move a little"


def test_mcap_compression_reaches_recorded_and_exported_bags(project: Path, tmp_path: Path) -> None:
    """`mcap_compression:` of a record step (formats: [mcap]) and of an export step set the bags' chunk compression,
    as `--mcap-compression` does; the default is zstd."""
    from tests.support.mcap import check_bag, chunk_compressions

    spec = write_yaml(
        tmp_path / "p.yaml",
        {
            "name": "compression",
            "steps": [
                {"id": "rec", "record": {"scenes": ["mock_pick"], "rskills": ["random-mock"], "seeds": {"count": 1},
                                         "max_steps": 4, "codec": "h264", "formats": ["lerobot", "mcap"],
                                         "mcap_compression": "lz4"}},
                {"id": "plain", "export": {"dataset": "rec", "mcap_compression": "none"}},
                {"id": "packed", "export": {"dataset": "rec"}},
            ],
        },
    )  # fmt: skip
    workdir = tmp_path / "run"
    run_pipeline(spec, workdir)
    item = "mock_pick--random-mock"
    for bags, expected in ((workdir / "rec" / item / "mcap", "lz4"), (workdir / "plain" / item, ""),
                           (workdir / "packed" / item, "zstd")):  # fmt: skip
        (bag,) = sorted(p for p in bags.iterdir() if p.is_dir())
        assert chunk_compressions(bag) == {expected}, bag
        assert check_bag(bag)


def test_a_moved_checkout_resumes_and_an_edited_scene_is_refused(project: Path, tmp_path: Path) -> None:
    """Step hashes take a scene file relative to the pipeline's folder with its content digest: a copy of the
    folder elsewhere skips what finished; a marker of the code before (absolute paths) is accepted while
    nothing moved and rewritten; an edited scene file makes the record step's configuration a changed one."""
    from openral_data.pipeline.state import config_hash
    from tests.support.scenes import mock_scene

    a, b = tmp_path / "a", tmp_path / "b"
    write_yaml(a / "scenes" / "pick.yaml", mock_scene(success_after=2, n_episodes=1))
    spec = write_yaml(
        a / "p.yaml",
        {"name": "moved", "steps": [
            {"id": "rec", "record": {"scenes": ["scenes/pick.yaml"], "rskills": ["zero-mock"],
                                     "seeds": {"count": 1}, "max_steps": 3, "codec": "h264"}},
            {"id": "all", "merge": {"inputs": ["rec"]}}]},
    )  # fmt: skip
    run_pipeline(spec, a / "run")
    shutil.copytree(a, b, symlinks=True)
    moved = b / "p.yaml"
    marker = b / "run" / "rec" / ".done.json"
    report = run_pipeline(moved, b / "run")  # the copy skips what finished, its outputs are the copy's
    assert [s["status"] for s in report.steps] == ["skipped", "skipped"]
    assert report.steps[1]["outputs"] == {"dataset": str(b / "run" / "all" / "dataset")}
    # a legacy marker (the absolute paths' hash, here b's) is accepted and rewritten with the portable hash
    body = json.loads(marker.read_text())
    legacy = config_hash(load_pipeline(moved).steps[0])
    assert body["config"] != legacy
    marker.write_text(json.dumps({**body, "config": legacy}))
    report = run_pipeline(moved, b / "run")
    assert [s["status"] for s in report.steps] == ["skipped", "skipped"]
    assert json.loads(marker.read_text())["config"] == body["config"]
    # the scene's meaning changes: the finished record step is refused, not silently reused
    scene = b / "scenes" / "pick.yaml"
    scene.write_text(scene.read_text().replace("success_after: 2", "success_after: 3"))
    with pytest.raises(ConfigError, match="step rec: its configuration changed"):
        run_pipeline(moved, b / "run")
