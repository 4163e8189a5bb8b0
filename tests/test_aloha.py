"""gym-aloha adapter: the same physics and reward as gym-aloha's own env, cameras from the YAML, exact restore,
record -> lerobot 0.6.1."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from sim_suite_helpers import (
    assert_same,
    build,
    lerobot_table,
    random_actions,
    roll,
    shipped,
    stats_per_task,
)
from suite_helpers import replay_reproduces

# ConfigError raises are matched by message on purpose: the file and field it names are the point
from openral_data.errors import ConfigError
from openral_data.record.sim import RecordOptions, record


@pytest.mark.slow
@pytest.mark.parametrize("scene_id", ["aloha_transfer_cube", "aloha_insertion"])
def test_states_and_rewards_equal_gym_alohas_own_env(scene_id: str) -> None:
    import gym_aloha  # noqa: F401  (registers the gymnasium ids)
    import gymnasium as gym

    gym_id = {"aloha_transfer_cube": "gym_aloha/AlohaTransferCube-v0", "aloha_insertion": "gym_aloha/AlohaInsertion-v0"}
    reference = gym.make(gym_id[scene_id], obs_type="pixels_agent_pos")
    env = build(shipped(scene_id, cameras=[]), "random-aloha")
    actions = random_actions("random-aloha", 8, seed=3)
    try:
        ref_obs, _ = reference.reset(seed=3)
        obs = env.reset(3)
        assert np.allclose(obs.state, ref_obs["agent_pos"], atol=1e-6)
        for a in actions:
            ref_obs, ref_reward, *_ = reference.step(a)
            r = env.step(a)
            assert np.allclose(r.observation.state, ref_obs["agent_pos"], atol=1e-6)
            assert r.reward == float(ref_reward)
        assert obs.time == 0.0 and r.observation.time == pytest.approx(8 * 0.02)
    finally:
        reference.close()
        env.close()


def test_cameras_and_sizes_come_from_the_yaml() -> None:
    env = build(shipped("aloha_transfer_cube", cameras=[("top", 160, 120), ("left_wrist", 64, 48)]), "random-aloha")
    try:
        obs = env.reset(0)
        assert obs.images["top"].shape == (120, 160, 3) and obs.images["left_wrist"].shape == (48, 64, 3)
        top = obs.images["top"].astype(int)
        red = (top[..., 0] > 150) & (top[..., 1] < 60) & (top[..., 2] < 60)  # the red cube seen from above
        assert red.sum() >= 2
        assert env.spec.fps == 50 and set(env.spec.cameras) == {"top", "left_wrist"}
    finally:
        env.close()
    with pytest.raises(ConfigError, match=r"scene.cameras\[0\].name: 'front' is not a camera.*valid: top, angle"):
        build(shipped("aloha_transfer_cube", cameras=[("front", 64, 64)]), "random-aloha")
    with pytest.raises(ConfigError, match=r"scene.params"):
        build(shipped("aloha_transfer_cube", task="stack"), "random-aloha")


def test_restore_reproduces_the_rollout_exactly() -> None:
    env = build(shipped("aloha_insertion", cameras=[("top", 64, 48)]), "random-aloha")
    actions = random_actions("random-aloha", 15, seed=11)
    try:
        first = roll(env, actions, env.reset(11))
        state = json.loads(json.dumps(env.initial_state()))
        roll(env, actions[:5], env.reset(12))  # another episode in between
        restored = roll(env, actions, env.reset_to(state))  # type: ignore[attr-defined]
        assert_same(first, restored)
        with pytest.raises(ConfigError, match="initial_state: task"):
            env.reset_to({**state, "task": "transfer_cube"})  # type: ignore[attr-defined]
    finally:
        env.close()


@pytest.mark.slow
def test_record_two_episodes_open_in_lerobot(project: Path, tmp_path: Path) -> None:
    out = tmp_path / "aloha"
    scene = shipped("aloha_transfer_cube", cameras=[("top", 96, 64)])
    path = project / "scenes/sim/aloha_small.yaml"
    path.write_text(json.dumps(scene.model_dump(mode="json")))
    summary = record(RecordOptions(scene=str(path), rskill="random-aloha", n_episodes=2, max_steps=12, seed=2, out=out))
    assert summary.frames == 24
    ds, cols = lerobot_table(out)
    assert len(ds) == 24 and ds.fps == 50 and ds.meta.robot_type == "aloha"
    assert ds.meta.video_keys == ["observation.images.top"]
    assert cols["observation.state"].shape == (24, 14) and not cols["next.success"].any()
    assert tuple(ds[5]["observation.images.top"].shape) == (3, 64, 96)
    second = cols["episode_index"] == 1
    assert np.array_equal(cols["action"][second], np.stack(random_actions("random-aloha", 12, seed=3)))
    replay_reproduces(out, tmp_path / "replay", episodes=2)
    group = stats_per_task(out)
    assert group["task"] == ds[0]["task"] and group["episodes"] == 2 and group["successes"] == 0
