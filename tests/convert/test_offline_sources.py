"""D4RL flat HDF5, Minari datasets and ManiSkill trajectories as `convert` / `info` sources: episodes cut where
the source says (D4RL's terminals/timeouts; Minari's and ManiSkill's episode groups, their T + 1 observation rows
aligned to T actions), values equal to h5py's and minari's own reads, success only from a real per-step signal
(never a terminal, a timeout or a done), the env id and control mode carried (ManiSkill)."""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Any

import h5py
import numpy as np
import pyarrow as pa
import pytest

import openral_data
from openral_data.convert import kinds
from openral_data.errors import ConfigError
from openral_data.formats.episodic import ArraySource
from openral_data.formats.lerobot_v3.encoder import VideoSettings
from openral_data.replay.recorded import RecordedDataset
from tests.support.array_sources import converted_episodes
from tests.support.inproc import run_inproc
from tests.support.offline_sources import write_d4rl, write_maniskill, write_minari

VIDEO_TOL = 8.0  # mean absolute pixel difference after h264 at 32x32


def _col(table: pa.Table, name: str) -> np.ndarray[Any, Any]:
    return np.array(table.column(name).to_pylist())


def _read(source: ArraySource | None, key: str) -> list[np.ndarray[Any, Any]]:
    """`key` of every episode as our reader gives it (the rows convert reads)."""
    assert source is not None
    try:
        return [ep.read(key, 0, ep.length) for ep in source.episodes()]
    finally:
        source.close()


def test_d4rl_episodes_end_at_terminals_and_timeouts(tmp_path: Path) -> None:
    """Rows 0-3 end at a terminal, 4-7 at a timeout, 8-10 are the unfinished rest; every value is the file's row;
    success is infos/goal_achieved (set on the terminal row), not the terminal or the timeout."""
    src = write_d4rl(tmp_path / "hopper-medium-v2.hdf5", rows=11, terminals=(3,), timeouts=(7,))
    found = kinds.detect(src)
    assert found is not None and found.kind.name == "hdf5-d4rl"
    found.handle.close()
    tables = converted_episodes(src, tmp_path / "out", 3, "--fps", "20")
    with h5py.File(src) as f:
        obs, act, rew, goal = (f[k][()] for k in ("observations", "actions", "rewards", "infos/goal_achieved"))
    for (a, b), rows in zip(((0, 4), (4, 8), (8, 11)), tables, strict=True):
        assert _col(rows, "observation.state").tolist() == obs[a:b].tolist()
        assert _col(rows, "action").tolist() == act[a:b].tolist()
        assert _col(rows, "next.reward").tolist() == rew[a:b].tolist()
        assert _col(rows, "next.success").tolist() == goal[a:b].tolist()
        assert _col(rows, "next.done").tolist() == [False] * (b - a - 1) + [True]
    assert [r.num_rows for r in tables] == [4, 4, 3]
    assert {f.task for f in RecordedDataset(tmp_path / "out").frames(0)} == {"hopper-medium-v2"}


def test_d4rl_without_a_goal_signal_maps_no_success(tmp_path: Path) -> None:
    """A file whose only end signals are terminals and timeouts: no success is mapped (a terminal is a fall as
    often as a goal) and the guess says why; a last row that ends an episode leaves no empty one after it."""
    folder = _walker(tmp_path)
    run = run_inproc("convert", str(folder), "--print-mapping", "--json")
    assert run.returncode == 0, run.stderr
    doc = json.loads(run.stdout)
    assert "success" not in doc["mapping"] and doc["guesses"]["success"].startswith("unknown")
    assert "terminals" in doc["guesses"]["success"]
    tables = converted_episodes(folder, tmp_path / "out", 3, "--fps", "20")
    assert [r.num_rows for r in tables] == [3, 3, 4]
    assert "next.success" not in tables[0].column_names


def _walker(tmp_path: Path) -> Path:
    folder = tmp_path / "walker"
    write_d4rl(folder / "a.hdf5", rows=6, terminals=(2,), timeouts=(5,), goal=False)
    write_d4rl(folder / "b.hdf5", rows=4, terminals=(), timeouts=(3,), goal=False)
    return folder


@pytest.mark.slow
def test_d4rl_folder_with_workers(tmp_path: Path) -> None:
    """A folder of two D4RL files split by file over --workers 2: the same episodes, in file order."""
    tables = converted_episodes(_walker(tmp_path), tmp_path / "out", 3, "--fps", "20", "--workers", "2")
    assert [r.num_rows for r in tables] == [3, 3, 4]
    assert _col(tables[2], "observation.state")[0].tolist() == [0.0, 0.25, 0.5, 0.75]  # b.hdf5's first row


@pytest.fixture(scope="module")
def minari_dataset(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return write_minari(tmp_path_factory.mktemp("minari"), (4, 3))


def test_minari_values_equal_minaris_own_read(minari_dataset: Path, tmp_path: Path) -> None:
    """Through the Python API: state / environment_state are observations rows 0..T-1, the action, reward as
    minari reads them, success is infos/success rows 1..T (the info of step(action t)); pictures as minari
    decodes its JPEGs; the dataset folder, its data folder and its main_data.hdf5 are the same source."""
    from minari.dataset.minari_dataset import MinariDataset  # type: ignore[import-untyped]

    theirs = list(MinariDataset(minari_dataset / "data").iterate_episodes())
    for path in (minari_dataset, minari_dataset / "data", minari_dataset / "data" / "main_data.hdf5"):
        found = kinds.detect(path)
        assert found is not None and found.kind.name == "minari", path
        found.handle.close()
    pictures = _read(kinds.detect(minari_dataset).handle, "observations/cam")  # type: ignore[union-attr]
    out = tmp_path / "out"
    summary = openral_data.convert(minari_dataset, out, fps=10, video=VideoSettings(codec="h264"))
    assert summary.frames == 7 and len(summary.episodes) == 2
    data = RecordedDataset(out)
    for e, ep in enumerate(theirs):
        frames = list(data.frames(e))
        assert len(frames) == len(ep) == len(ep.actions)
        assert [f.state.tolist() for f in frames] == ep.observations["agent"][:-1].tolist()
        env = [f.environment_state.tolist() for f in frames if f.environment_state is not None]
        assert env == ep.observations["desired_goal"][:-1].astype(np.float32).tolist()
        assert [f.action.tolist() for f in frames] == ep.actions.tolist()
        assert [f.reward for f in frames] == ep.rewards.astype(np.float32).tolist()
        assert [f.success for f in frames] == ep.infos["success"][1:].tolist()
        assert {f.task for f in frames} == {"toy/reach-v0"}
        assert np.array_equal(pictures[e], ep.observations["cam"][:-1])
        got = np.stack([f.images["cam"] for f in frames]).astype(np.float64)
        assert np.abs(got - ep.observations["cam"][:-1]).mean() <= VIDEO_TOL


def test_maniskill_values_equal_h5py_and_its_json(tmp_path: Path) -> None:
    """State is qpos then qvel rows 0..T-1 (the last obs row, after the last action, left out), actions named by
    the control mode, success the per-step `success`, the env id the task, the robot from env_kwargs; the
    camera's rgb as stored (within video tolerance after encoding); depth listed by info, not mapped."""
    src = write_maniskill(tmp_path / "ms" / "trajectory.rgbd.pd_joint_delta_pos.h5", (5, 3))
    info = run_inproc("info", str(src), "--json")
    assert info.returncode == 0, info.stderr
    assert json.loads(info.stdout)["layout"] == "maniskill"
    tables = converted_episodes(src, tmp_path / "out", 2, "--fps", "20")
    meta = json.loads((tmp_path / "out" / "meta" / "info.json").read_text())
    assert meta["robot_type"] == "panda"
    assert meta["features"]["action"]["names"][:2] == ["pd_joint_delta_pos_0", "pd_joint_delta_pos_1"]
    data = RecordedDataset(tmp_path / "out")
    with h5py.File(src) as f:
        for e, rows in enumerate(tables):
            g = f[f"traj_{e}"]
            n = g["actions"].shape[0]
            state = np.concatenate([g["obs/agent/qpos"][:n], g["obs/agent/qvel"][:n]], axis=1)
            assert _col(rows, "observation.state").tolist() == state.tolist()
            assert _col(rows, "action").tolist() == g["actions"][()].tolist()
            assert _col(rows, "next.success").tolist() == g["success"][()].tolist()
            assert _col(rows, "next.reward").tolist() == g["rewards"][()].tolist()
            frames = list(data.frames(e))
            assert {fr.task for fr in frames} == {"PickCube-v1"}
            got = np.stack([fr.images["base_camera"] for fr in frames]).astype(np.float64)
            assert np.abs(got - g["obs/sensor_data/base_camera/rgb"][:n]).mean() <= VIDEO_TOL
    assert "observation.images.depth" not in meta["features"]


def test_robomimic_and_aloha_are_still_read_as_before(tmp_path: Path) -> None:
    """The HDF5 kinds added after them take no robomimic or ALOHA file (their layout is decided first)."""
    from tests.support.hdf5_layouts import write_aloha, write_robomimic

    for path, name in ((write_robomimic(tmp_path / "lift.hdf5", (3,)), "hdf5-robomimic"),
                       (write_aloha(tmp_path / "aloha", (3,)), "hdf5-aloha")):  # fmt: skip
        found = kinds.detect(path)
        assert found is not None and found.kind.name == name
        found.handle.close()


def test_minari_without_the_extra_is_one_line_naming_it(
    minari_dataset: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Without minari installed a Minari dataset is one line naming the extra (nothing written); other sources
    never import minari."""
    for name in ("minari", "minari.dataset", "minari.dataset.minari_storage", "minari.serialization"):
        monkeypatch.setitem(sys.modules, name, None)  # `import minari...` raises ImportError
    src = write_d4rl(tmp_path / "hopper.hdf5", rows=4, terminals=(3,), timeouts=())
    found = kinds.detect(src)
    assert found is not None and found.kind.name == "hdf5-d4rl"
    found.handle.close()
    out = tmp_path / "out"
    with pytest.raises(
        ConfigError, match=r"Minari datasets need the 'minari' extra: pip install 'openral-data\[minari\]'"
    ):
        openral_data.convert(minari_dataset, out, fps=10)
    assert not out.exists()


def test_minari_box_observation_and_discrete_action(tmp_path: Path) -> None:
    """A Box observation space is one dataset (`observations`): the state; a Discrete action one number a step."""
    from minari.dataset.minari_dataset import MinariDataset  # type: ignore[import-untyped]

    folder = write_minari(tmp_path / "datasets", (3, 2), box=True)
    tables = converted_episodes(folder, tmp_path / "out", 2, "--fps", "10")
    for ep, rows in zip(MinariDataset(folder / "data").iterate_episodes(), tables, strict=True):
        assert _col(rows, "observation.state").tolist() == ep.observations[:-1].tolist()
        assert _col(rows, "action").tolist() == [float(a) for a in ep.actions]  # a 1-wide feature: a scalar column
        assert _col(rows, "next.success").tolist() == ep.infos["success"][1:].tolist()
