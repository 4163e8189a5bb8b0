"""`replay --mode policy`: recorded observations (decoded video + state + task) to a policy, actions compared."""

from __future__ import annotations

import shutil
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest
import yaml

# CompatibilityError raises are matched by message on purpose: the file and field it names are the point
from openral_data.errors import CompatibilityError, ReplayError
from openral_data.formats.lerobot_v3 import layout
from openral_data.formats.results import open_results
from openral_data.replay import ReplayOptions, replay
from openral_data.replay.recorded import RecordedDataset
from tests.support.home import isolated_home
from tests.support.replay import record_mock
from tests.support.scenes import write_yaml


@pytest.fixture(scope="module")
def mock(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[Path, Path]]:
    """A mock dataset (random actions, two cameras) and its project home."""
    base = tmp_path_factory.mktemp("mock")
    with isolated_home(base) as home:
        yield record_mock(home, base / "mock").out, home


def _zero_rskill(home: Path, dim: int = 7) -> Path:
    data = yaml.safe_load((home / "rskills/random-mock/rskill.yaml").read_text())
    data.update(id="zero-eval", policy="zero")
    data["action_contract"].update(dim=dim, names=[f"a{i}" for i in range(dim)], low=None, high=None)
    return write_yaml(home / "rskills/zero-eval/rskill.yaml", data)


@pytest.mark.parametrize("ref", ["recorded", "recorded:3", "recorded:100"])
def test_the_recorded_policy_gives_exactly_zero_error(mock: tuple[Path, Path], tmp_path: Path, ref: str) -> None:
    dataset, _ = mock
    summary = replay(ReplayOptions(dataset, mode="policy", rskill=ref, out=tmp_path / "res"))
    assert summary.summary["mode"] == "policy"
    assert summary.summary["steps"] == sum(RecordedDataset(dataset).episode(e).length for e in range(3))
    assert summary.summary["action_mse_mean"] == 0.0 and summary.summary["action_mae_mean"] == 0.0
    steps = pq.read_table(open_results(tmp_path / "res").steps_path)
    assert steps.num_rows == summary.summary["steps"]
    assert set(steps.column("action_error").to_pylist()) == {0.0}
    chunk = int(ref.partition(":")[2] or 1)
    assert summary.summary["chunk"] == {"n_action_steps": chunk}


def test_a_different_policy_gives_a_positive_error_of_the_right_shape(mock: tuple[Path, Path], tmp_path: Path) -> None:
    dataset, home = mock
    rskill = _zero_rskill(home)
    summary = replay(ReplayOptions(dataset, mode="policy", rskill=str(rskill), out=tmp_path / "res", episodes="1,2"))
    assert summary.summary["mode"] == "policy"
    recorded = RecordedDataset(dataset)
    for o in summary.episodes:
        ep = recorded.episode(o.index)
        assert o.action_abs is not None and o.action_abs.shape == ep.actions.shape  # (steps, action dims)
        np.testing.assert_allclose(o.action_abs, np.abs(ep.actions), rtol=0, atol=0)  # zero policy: |recorded|
        assert o.success_replayed is None  # offline: nothing executed
    eps = pq.read_table(open_results(tmp_path / "res").episodes_path).to_pylist()
    assert [len(e["action_mse"]) for e in eps] == [7, 7] and all(min(e["action_mse"]) > 0 for e in eps)
    ep1 = recorded.episode(1).actions.astype(np.float64)
    np.testing.assert_allclose(eps[0]["action_mse"], (ep1**2).mean(axis=0))
    np.testing.assert_allclose(eps[0]["action_mae"], np.abs(ep1).mean(axis=0))
    names = recorded.info["features"]["action"]["names"]
    assert list(summary.summary["action_mae"]) == names and summary.summary["action_mse_mean"] > 0


def test_policy_mode_needs_no_simulator_or_provenance(mock: tuple[Path, Path], tmp_path: Path) -> None:
    """A dataset without meta/openral.json (as converted from bags) is evaluated all the same."""
    copy = tmp_path / "converted"
    shutil.copytree(mock[0], copy)
    (copy / layout.OPENRAL_PATH).unlink()
    summary = replay(ReplayOptions(copy, mode="policy", rskill="recorded:2", out=tmp_path / "res"))
    assert summary.summary["mode"] == "policy"
    assert summary.summary["action_mae_mean"] == 0.0
    with pytest.raises(ReplayError, match="not recorded by openral-data") as excinfo:  # why: only the wording says
        replay(ReplayOptions(copy, out=tmp_path / "res2"))
    assert excinfo.value.code == "replay"


def test_a_policy_whose_contract_does_not_fit_the_dataset_is_refused(mock: tuple[Path, Path], tmp_path: Path) -> None:
    dataset, home = mock
    rskill = _zero_rskill(home, dim=6)
    with pytest.raises(CompatibilityError, match=r"action_contract.dim: 6 but dataset .* records action of 7 dims"):
        replay(ReplayOptions(dataset, mode="policy", rskill=str(rskill), out=tmp_path / "res"))
    assert not (tmp_path / "res").exists()


class _FrameReader:
    """Answers with the recorded action of the frame its state names; notes what the decoded image shows (the mock
    paints frame t of episode e as (t, e, 128))."""

    def __init__(self, actions: np.ndarray) -> None:
        self.actions = actions
        self.seen: list[tuple[int, float, float]] = []

    def reset(self, seed: int) -> None:
        pass

    def step(self, observation: object, instruction: str) -> np.ndarray:
        from openral_data.types import Observation

        assert isinstance(observation, Observation) and instruction == "pick up the mock cube"
        colour = observation.images["front"].reshape(-1, 3).mean(axis=0)
        t_state = int(observation.state[0])
        self.seen.append((t_state, float(colour[0]), float(colour[1])))
        return np.asarray(self.actions[t_state], dtype=np.float32)

    def close(self) -> None:
        pass


def test_decoded_frames_state_and_actions_are_aligned(mock: tuple[Path, Path]) -> None:
    from openral_data.replay.policy_mode import evaluate_episode

    dataset = RecordedDataset(mock[0])
    episode = dataset.episode(2)
    policy = _FrameReader(episode.actions)
    outcome = evaluate_episode(dataset, 2, policy)
    assert [t for t, _, _ in policy.seen] == list(range(episode.length))
    for t, red, green in policy.seen:  # the decoded image is this row's, within the codec's colour tolerance
        assert abs(red - t) <= 4 and abs(green - 2) <= 4, (t, red, green)
    assert outcome.action_abs is not None and outcome.action_abs.max() == 0.0


class _Watcher:
    """Answers with the recorded action and keeps the observations it was given."""

    def __init__(self, actions: np.ndarray) -> None:
        self.actions = actions
        self.seen: list[object] = []

    def reset(self, seed: int) -> None:
        pass

    def step(self, observation: object, instruction: str) -> np.ndarray:
        self.seen.append(observation)
        return np.asarray(self.actions[len(self.seen) - 1], dtype=np.float32)

    def close(self) -> None:
        pass


@pytest.mark.slow
@pytest.mark.parametrize("with_success", [True, False])
def test_a_dataset_lerobot_wrote_is_evaluated(tmp_path: Path, with_success: bool) -> None:
    """No openral.* columns, a video and a `dtype: image` camera, environment state: every frame reaches the policy
    (the image camera's PNG pixels exactly), and the recorded success is the one rule's (any next.success)."""
    from openral_data.replay.policy_mode import evaluate_episode
    from openral_data.types import Observation
    from tests.support.lerobot_written import LENGTHS, SUCCEEDED, image_pixels, write_lerobot_dataset

    root = tmp_path / "lerobot"
    write_lerobot_dataset(root, with_success, image_camera=True, environment_state=True)
    summary = replay(ReplayOptions(root, mode="policy", rskill="recorded:2", out=tmp_path / "res"))
    assert summary.summary["mode"] == "policy"
    assert summary.summary["steps"] == sum(LENGTHS) and summary.summary["action_mae_mean"] == 0.0
    expected = SUCCEEDED if with_success else [None] * len(LENGTHS)
    assert [o.success_recorded for o in summary.episodes] == expected

    dataset = RecordedDataset(root)
    assert sorted(dataset.cameras) == ["cam", "wrist"]
    episode = dataset.episode(1)
    policy = _Watcher(episode.actions)
    evaluate_episode(dataset, 1, policy)
    assert len(policy.seen) == LENGTHS[1]
    for t, obs in enumerate(policy.seen):
        assert isinstance(obs, Observation)
        np.testing.assert_array_equal(obs.images["wrist"], image_pixels(1, t))
        np.testing.assert_array_equal(obs.state, episode.states[t])
