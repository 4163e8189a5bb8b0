"""`replay` in the simulator: recorded actions (`--mode actions`), policies from the recorded starts (`--mode
closed-loop`) and re-recording (`--record`), in the scene rebuilt from the dataset's own record."""

from __future__ import annotations

import json
import os
from collections.abc import Iterator
from dataclasses import replace
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest
import yaml

from openral_data.errors import OutputExists, ReplayError
from openral_data.formats.results import open_results
from openral_data.metrics.command import StatsOptions, run_stats
from openral_data.producers.sim.mock import MockScene
from openral_data.replay import ReplayOptions, replay
from openral_data.replay.actions import DEFAULT_TOLERANCE, ActionReplayer
from openral_data.replay.rebuild import SceneView, rebuild
from openral_data.replay.recorded import RecordedDataset
from openral_data.runtime import registry
from tests.support.cli import run_cli
from tests.support.home import isolated_home
from tests.support.replay import record_mock, record_push
from tests.support.scenes import write_yaml


@pytest.fixture(scope="module")
def push(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Path]:
    """3 scripted-expert tabletop_push episodes (real MuJoCo, 64x64 front camera, h264)."""
    base = tmp_path_factory.mktemp("push")
    with isolated_home(base) as home:
        summary = record_push(home, base / "push", n_episodes=3, seed=3)
        assert summary.success_rate == 1.0
        yield summary.out


@pytest.fixture(scope="module")
def mock(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Path]:
    base = tmp_path_factory.mktemp("mock")
    with isolated_home(base) as home:
        yield record_mock(home, base / "mock").out


def test_push_replay_reproduces_every_episode_within_tolerance(push: Path, tmp_path: Path) -> None:
    summary = replay(ReplayOptions(push, out=tmp_path / "res"))
    assert summary.summary["mode"] == "actions"
    recorded = RecordedDataset(push)
    assert [o.index for o in summary.episodes] == [0, 1, 2]
    for o in summary.episodes:
        ep = recorded.episode(o.index)
        assert o.success_recorded is True and o.success_replayed is True
        assert o.steps == ep.length and len(o.frames) == ep.length
        assert o.state_abs is not None and o.state_abs.shape == ep.states.shape
        assert float(o.state_abs.max()) <= DEFAULT_TOLERANCE and o.first_divergence_frame is None
        assert o.object_error_initial is not None and o.object_error_initial < 1e-9  # cube restored exactly
    assert summary.summary["reproduced"] == 3 and summary.summary["success_agree"] == 3

    res = open_results(tmp_path / "res")
    assert res.summary["kind"] == "replay" and res.summary["mode"] == "actions"
    steps = pq.read_table(res.steps_path)
    assert steps.num_rows == sum(recorded.episode(e).length for e in range(3))
    assert len(steps.column("state_abs_error")[0].as_py()) == 8  # per state dimension
    report = json.loads(run_stats(StatsOptions([str(push), str(tmp_path / "res")], fmt="json", health=False)))
    rows = report["results"]
    assert rows[0]["outcome_agree"] == 3 and rows[0]["divergence_max"] == 0


def test_perturbed_actions_are_detected(push: Path) -> None:
    dataset = RecordedDataset(push)
    ep = dataset.episode(1)
    actions = ep.actions.copy()
    actions[5:, 0] = -actions[5:, 0]  # push the other way along x from step 5 on
    actions[5:, 1] += 0.01
    built = rebuild(dataset, view=SceneView(cameras=()))
    try:
        outcome = ActionReplayer(built.env).replay(replace(ep, actions=actions))
    finally:
        built.env.close()
    assert outcome.first_divergence_frame is not None and 5 < outcome.first_divergence_frame <= 8
    assert outcome.success_recorded is True and outcome.success_replayed is False
    assert outcome.success_agrees is False
    div = outcome.divergence
    assert div is not None and div[:6].max() == 0 and div[-1] > 0.01


def test_mock_scene_restores_its_state_and_cli_prints_a_summary(mock: Path, tmp_path: Path) -> None:
    out = tmp_path / "res"
    proc = run_cli("replay", str(mock), "--episodes", "0,2", "--out", str(out))
    assert proc.returncode == 0, proc.stderr
    assert "reproduced        2/2 episodes" in proc.stdout and "success agrees    2/2 episodes" in proc.stdout
    res = open_results(out)
    eps = pq.read_table(res.episodes_path).to_pylist()
    assert [e["episode_index"] for e in eps] == [0, 2]
    assert [e["success_recorded"] for e in eps] == [True, False]  # success_after 9 > max_steps 8
    assert [e["success_replayed"] for e in eps] == [True, False]
    assert all(e["divergence_max"] == 0 for e in eps)


def _main(capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch, *args: str) -> tuple[int, str]:
    """The real entry point (`openral_data.cli.main`) in-process: exit status and stderr."""
    from openral_data.cli import main

    monkeypatch.setattr("sys.argv", ["openral-data", *args])
    with pytest.raises(SystemExit) as exit_info:
        main()
    return int(exit_info.value.code or 0), capsys.readouterr().err


def test_cli_errors_are_one_line(
    mock: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    for args, needle in (
        (["--mode", "policy"], "--mode policy needs --rskill"),
        (["--episodes", "7"], "outside the dataset's episodes 0..2"),
        (["--mode", "bogus"], "--mode: 'bogus' is not one of"),
        (["--tolerance", "-1"], "--tolerance must be"),
    ):
        code, err = _main(capsys, monkeypatch, "replay", str(mock), "--out", str(tmp_path / "x"), *args)
        assert code == 2 and needle in err, err
        assert len(err.strip().splitlines()) == 1 and not (tmp_path / "x").exists()
    code, err = _main(capsys, monkeypatch, "replay", str(tmp_path))
    assert code == 2 and "not a LeRobot v3 dataset" in err


def test_a_scene_that_cannot_restore_is_refused_by_type(
    mock: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    class NoRestore(MockScene):
        def __init__(self, *args: object, **kw: object) -> None:
            super().__init__(*args, **kw)  # type: ignore[arg-type]
            self.spec = replace(self.spec, can_restore_state=False)

    monkeypatch.setitem(registry.SCENES, "mock", lambda scene, robot, rskill, src: NoRestore(scene, 8, src))
    # the code says "cannot replay"; the field and scene type named in the wording are the point, matched too
    with pytest.raises(
        ReplayError, match=r"scene.type: 'mock' scenes cannot restore a recorded initial state"
    ) as excinfo:
        replay(ReplayOptions(mock, out=tmp_path / "res"))
    assert excinfo.value.code == "replay"
    assert not (tmp_path / "res").exists()


def test_replay_rebuilds_the_recorded_scene_not_todays_yaml(mock: Path, tmp_path: Path) -> None:
    """Editing the scene file after recording changes nothing: the recorded config is used."""
    recorded = RecordedDataset(mock)
    origin = recorded.provenance
    assert origin is not None and origin.scene is not None and origin.scene.path is not None
    scene_path = Path(origin.scene.path)
    scene_path.write_text("tier: sim\nscene: {broken")
    summary = replay(ReplayOptions(mock, out=tmp_path / "res"))
    assert summary.summary["mode"] == "actions"
    assert summary.summary["reproduced"] == 3
    assert summary.summary["divergence_max"] is not None and np.isclose(summary.summary["divergence_max"], 0.0)


def _rskill_like(home: Path, source: str, **changes: object) -> Path:
    data = yaml.safe_load((home / f"rskills/{source}/rskill.yaml").read_text())
    data.update(changes)
    return write_yaml(home / f"rskills/{data['id']}/rskill.yaml", data)


def test_closed_loop_pairs_success_episode_by_episode(push: Path, tmp_path: Path) -> None:
    home = Path(os.environ["OPENRAL_DATA_HOME"])
    expert = replay(ReplayOptions(push, mode="closed-loop", rskill="scripted-push", out=tmp_path / "expert"))
    assert expert.summary["mode"] == "closed-loop"
    assert expert.summary["paired"] == {"both": 3, "only_recorded": 0, "only_policy": 0, "neither": 0}
    recorded = RecordedDataset(push)
    for o in expert.episodes:  # the recorded policy from the recorded start: the same rollout
        assert o.steps == recorded.episode(o.index).length and o.first_divergence_frame is None

    zero = _rskill_like(home, "scripted-push", id="zero-push", policy="zero")
    idle = replay(ReplayOptions(push, mode="closed-loop", rskill=str(zero), max_steps=15, out=tmp_path / "zero"))
    assert idle.summary["mode"] == "closed-loop"
    assert idle.summary["paired"] == {"both": 0, "only_recorded": 3, "only_policy": 0, "neither": 0}
    assert all(o.steps == 15 and o.success_replayed is False for o in idle.episodes)
    res = open_results(tmp_path / "zero")
    assert res.summary["kind"] == "eval" and res.summary["mode"] == "closed-loop"


@pytest.mark.slow
def test_rerecord_with_other_cameras_loads_in_lerobot_and_replays(push: Path, tmp_path: Path) -> None:
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    cams = write_yaml(
        tmp_path / "cams.yaml",
        {
            "cameras": [
                {"name": "overhead", "width": 80, "height": 64, "pos": [0.85, 0.0, 1.9], "lookat": [0.52, 0.0, 0.8]},
                {"name": "wrist", "width": 48, "height": 48, "mount": "wrist"},
            ]
        },
    )
    out = tmp_path / "rendered"
    summary = replay(ReplayOptions(push, out=tmp_path / "res", record=out, cameras=cams, codec="h264", episodes="0,2"))
    assert summary.summary["mode"] == "actions"
    assert summary.summary["record"] == {
        "out": str(out),
        "episodes": 2,
        "frames": sum(o.steps for o in summary.episodes),
    }

    ds = LeRobotDataset("local/rendered", root=out, video_backend="pyav")
    assert ds.meta.total_episodes == 2 and len(ds) == summary.summary["record"]["frames"]
    assert ds[0]["observation.images.overhead"].shape == (3, 64, 80)
    assert ds[0]["observation.images.wrist"].shape == (3, 48, 48)
    assert "observation.images.front" not in ds.meta.features
    original, rendered = RecordedDataset(push), RecordedDataset(out)
    for new, old in ((0, 0), (1, 2)):
        np.testing.assert_array_equal(rendered.episode(new).states, original.episode(old).states)
        np.testing.assert_array_equal(rendered.episode(new).actions, original.episode(old).actions)
        assert rendered.episode(new).success is True and rendered.episode(new).seed == original.episode(old).seed
    again = replay(ReplayOptions(out, out=tmp_path / "res2"))  # the new dataset is itself replayable
    assert again.summary["mode"] == "actions"
    assert again.summary["reproduced"] == 2


def test_rerecord_refuses_an_existing_dataset(push: Path, tmp_path: Path) -> None:
    out = tmp_path / "taken"
    out.mkdir()
    (out / "keep.txt").write_text("mine")
    with pytest.raises(OutputExists) as excinfo:
        replay(ReplayOptions(push, out=tmp_path / "res", record=out, episodes="0"))
    assert excinfo.value.code == "output.exists"
    assert (out / "keep.txt").read_text() == "mine" and not (tmp_path / "res").exists()
