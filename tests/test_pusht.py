"""gym-pusht adapter: gym-pusht's own physics, camera and success; exact restore; record -> lerobot 0.6.1."""

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


def test_camera_and_size_come_from_the_yaml_and_the_view_shows_the_scene() -> None:
    env = build(shipped("pusht", cameras=[("top", 128, 96)]), "random-pusht")
    try:
        assert env.spec.cameras["top"].height == 96 and env.spec.cameras["top"].width == 128 and env.spec.fps == 10
        obs = env.reset(3)
        img = obs.images["top"]
        assert img.shape == (96, 128, 3) and img.dtype == np.uint8
        green = (img[..., 1] > 180) & (img[..., 0] < 180) & (img[..., 2] < 180)  # gym-pusht's LightGreen goal T
        assert green.sum() > 50
        assert obs.state.shape == (2,) and obs.time == 0.0
        assert "block_pos" in obs.privileged  # ground truth for experts, never recorded
    finally:
        env.close()
    no_cam = build(shipped("pusht", cameras=[]), "random-pusht")
    try:
        assert no_cam.reset(3).images == {} and no_cam.spec.cameras == {}
    finally:
        no_cam.close()


def test_bad_yaml_is_named() -> None:
    with pytest.raises(ConfigError, match=r"scene.cameras\[0\].name: 'front' is not a camera.*valid: top"):
        build(shipped("pusht", cameras=[("front", 96, 96)]), "random-pusht")
    scene = shipped("pusht")
    scene = scene.model_copy(update={"scene": scene.scene.model_copy(update={"fps": 20})})
    with pytest.raises(ConfigError, match=r"scene.fps: this simulator steps at 10 Hz"):
        build(scene, "random-pusht")
    with pytest.raises(ConfigError, match=r"scene.params"):
        build(shipped("pusht", colour="red"), "random-pusht")


def test_seeded_reset_and_restore_reproduce_the_rollout_exactly() -> None:
    env = build(shipped("pusht"), "random-pusht")
    actions = random_actions("random-pusht", 25, seed=7)
    try:
        first = roll(env, actions, env.reset(7))
        state = json.loads(json.dumps(env.initial_state()))
        again = roll(env, actions, env.reset(7))
        other = env.reset(8)
        assert not np.array_equal(other.state, first[0][0]) or env.initial_state() != state
        restored = roll(env, actions, env.reset_to(state))  # type: ignore[attr-defined]
        assert_same(first, again)
        assert_same(first, restored)
        assert env.spec.can_restore_state
        with pytest.raises(ConfigError, match="initial_state: kind"):
            env.reset_to({**state, "kind": "gym_aloha"})  # type: ignore[attr-defined]
    finally:
        env.close()


def test_success_is_gym_pushts_coverage_test() -> None:
    env = build(shipped("pusht", cameras=[]), "random-pusht")
    try:
        env.reset(1)
        inner = env.env  # type: ignore[attr-defined]
        r = env.step(np.array([50.0, 450.0], dtype=np.float32))
        assert not r.success and not r.terminated and r.reward < 1.0
        inner.block.angle = inner.goal_pose[2]  # pymunk turns about the T's centre of gravity: angle first
        inner.block.position = tuple(inner.goal_pose[:2])  # the T exactly on the goal
        inner.agent.position, inner.agent.velocity = (50.0, 450.0), (0.0, 0.0)  # agent out of the way
        r = env.step(np.array([50.0, 450.0], dtype=np.float32))
        assert r.success and r.terminated and r.reward == 1.0 and r.observation.privileged["coverage"] > 0.95
    finally:
        env.close()


@pytest.mark.slow
def test_record_two_episodes_open_in_lerobot(project: Path, tmp_path: Path) -> None:
    out = tmp_path / "pusht"
    summary = record(RecordOptions(scene="pusht", rskill="random-pusht", n_episodes=2, max_steps=15, seed=4, out=out))
    assert summary.frames == 30 and len(summary.episodes) == 2
    ds, cols = lerobot_table(out)
    assert len(ds) == 30 and ds.meta.video_keys == ["observation.images.top"] and ds.fps == 10
    assert ds.meta.robot_type == "pusht_agent"
    assert ds[0]["task"] == "Push the T-shaped block onto the T-shaped target."
    # the dataset holds exactly what the scene produced and the policy emitted
    env = build(shipped("pusht"), "random-pusht")
    try:
        actions = random_actions("random-pusht", 15, seed=4)
        states = roll(env, actions, env.reset(4))[0]
    finally:
        env.close()
    first = cols["episode_index"] == 0
    assert np.array_equal(cols["observation.state"][first], np.stack(states[:15]))
    assert np.array_equal(cols["action"][first], np.stack(actions))
    img = ds[0]["observation.images.top"]
    assert tuple(img.shape) == (3, 96, 96)
    replay_reproduces(out, tmp_path / "replay", episodes=2)
    group = stats_per_task(out)
    assert group["task"] == ds[0]["task"] and group["episodes"] == 2 and group["successes"] == 0


def test_fixed_robot_refuses_another_robot(project: Path, tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match=r"scene.fixed_robot.*pusht_agent"):
        record(RecordOptions(scene="pusht", rskill="random-pusht", robot="franka_panda", out=tmp_path / "x"))
    assert not (tmp_path / "x").exists()
