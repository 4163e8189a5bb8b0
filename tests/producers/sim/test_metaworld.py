"""MetaWorld scenes (metaworld 3.1.1, gymnasium API): expert success, seeds, restore, upright cameras, records."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest

# ConfigError raises are matched by message on purpose: the file and field it names are the point
from openral_data.errors import ConfigError
from openral_data.policies.metaworld_expert import policy_class_name
from openral_data.producers.sim.metaworld import task_names
from openral_data.record.options import RecordOptions
from openral_data.record.sim import record
from tests.support.suites import (
    env_and_policy,
    project_point,
    replay_reproduces,
    rollout,
    small_scene_file,
    stats_groups,
)

pytest.importorskip("metaworld")

# five tasks with shipped scenes (scenes/sim/metaworld_*.yaml); push is the sixth
TASKS = ["metaworld_pick_place", "metaworld_door_open", "metaworld_drawer_open", "metaworld_button_press_topdown",
         "metaworld_window_open", "metaworld_push"]  # fmt: skip


def _success_rate(scene_id: str, seeds: range) -> tuple[int, list[int]]:
    env, expert = env_and_policy(scene_id, "metaworld-expert")
    wins, lengths = 0, []
    try:
        for seed in seeds:
            obs = env.reset(seed)
            expert.reset(seed)
            run = rollout(env, expert, obs, 500)
            wins += bool(run["successes"] and run["successes"][-1])
            lengths.append(len(run["actions"]))
    finally:
        env.close()
    return wins, lengths


def test_every_metaworld_task_has_an_expert_class() -> None:
    from metaworld import policies

    names = task_names()
    assert len(names) == 50
    missing = [t for t in names if not hasattr(policies, policy_class_name(t))]
    assert not missing


@pytest.mark.parametrize("scene_id", TASKS[:5])
def test_expert_solves_the_task_on_a_few_seeds(scene_id: str) -> None:
    wins, lengths = _success_rate(scene_id, range(2))
    assert wins == 2, (scene_id, lengths)
    assert max(lengths) < 500


@pytest.mark.slow
@pytest.mark.parametrize("scene_id", TASKS)
def test_expert_succeeds_at_least_90_percent_over_20_seeds(scene_id: str) -> None:
    wins, lengths = _success_rate(scene_id, range(1000, 1020))
    assert wins >= 18, (scene_id, wins, lengths)


@pytest.mark.parametrize("scene_id", ["metaworld_pick_place", "metaworld_drawer_open"])
def test_seed_is_one_initial_state_and_reset_to_replays_bit_for_bit(scene_id: str) -> None:
    """drawer-open places the drawer by editing the model; writing a state back drifts there, reproducing does not."""
    env, expert = env_and_policy(scene_id, "metaworld-expert")
    try:
        assert env.spec.can_restore_state and env.spec.fps == 80 and env.spec.state_dim == 4
        obs = env.reset(11)
        initial = json.loads(json.dumps(env.initial_state()))  # as stored in meta/episodes
        first = rollout(env, expert, obs, 60)
        other = env.reset(12)
        assert env.initial_state()["rand_vec"] != initial["rand_vec"]  # another seed, another placement
        assert other.time == 0.0
        env.step(np.ones(4, dtype=np.float32))
        again = rollout(env, expert, env.reset_to(initial), 60, actions=first["actions"])
        assert np.array_equal(again["states"], first["states"])
        assert again["rewards"] == first["rewards"] and again["successes"] == first["successes"]
        assert env.reset(11).time == 0.0 and json.loads(json.dumps(env.initial_state())) == initial

        with pytest.raises(ConfigError, match="initial_state: task: recorded on 'reach-v3'"):
            env.reset_to({**initial, "task": "reach-v3"})
        tampered = json.loads(json.dumps(initial))
        tampered["mujoco"]["integration_state"][1] += 1e-3
        with pytest.raises(ConfigError, match="initial_state: mujoco: MetaWorld's reset with seed 11 does not"):
            env.reset_to(tampered)
        with pytest.raises(ConfigError, match="initial_state: rand_vec: this MetaWorld draws another placement"):
            env.reset_to({**initial, "rand_vec": [0.0] * len(initial["rand_vec"])})
    finally:
        env.close()


def test_cameras_are_upright_the_puck_is_where_the_geometry_says() -> None:
    """corner2 renders upside down in MetaWorld (lerobot flips it). Two seeds differ only in where the puck (and
    the invisible goal) is: the pixels that change must be at the puck's projections into an upright image, not at
    the mirrored ones."""
    size = 96
    env, _ = env_and_policy(
        "metaworld_pick_place", "metaworld-expert", cameras=[("corner2", size, size), ("corner", size, size)]
    )
    try:
        u = env.u  # type: ignore[attr-defined]
        seen = []
        for seed in (3, 4):
            obs = env.reset(seed)
            pucks = {cam: project_point(u.model, u.data, cam, obs.privileged["metaworld_obs"][4:7], size, size)
                     for cam in obs.images}  # fmt: skip
            seen.append((obs.images, pucks))
        (first, pucks_a), (second, pucks_b) = seen
        for cam in ("corner2", "corner"):
            changed = np.abs(first[cam].astype(int) - second[cam].astype(int)).sum(axis=2) > 40
            assert changed.any()
            for row, col in (pucks_a[cam], pucks_b[cam]):
                assert changed[row - 1 : row + 2, col - 1 : col + 2].any(), (cam, row, col)
                r, c = size - 1 - row, size - 1 - col
                assert not changed[r - 1 : r + 2, c - 1 : c + 2].any(), (cam, "mirrored", r, c)
    finally:
        env.close()


def _record_bench(project: Path, tmp_path: Path, scene_id: str, n: int) -> Path:
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    scene = small_scene_file(project, scene_id, size=32)
    out = tmp_path / scene_id
    summary = record(RecordOptions(scene=str(scene), n_episodes=n, out=out))  # the scene's default_rskill
    assert summary.success_rate == 1.0
    used = json.loads((out / ".openral/record.json").read_text())["options"]["rskill"]
    assert used.endswith("/metaworld-expert/rskill.yaml")
    ds = LeRobotDataset(f"local/{scene_id}", root=out, video_backend="pyav")
    assert len(ds) == summary.frames and ds.fps == 80 and ds.meta.robot_type == "metaworld_sawyer"
    assert ds.meta.video_keys == ["observation.images.corner2", "observation.images.gripperPOV"]
    assert [int(x) for x in ds.meta.episodes["openral.seed"]] == list(range(1000, 1000 + n))
    last = ds[summary.episodes[0].length - 1]
    assert float(last["next.success"]) == 1.0 and last["task"] == ds.meta.tasks.index[0]
    table = ds.hf_dataset.with_format("numpy")
    actions = np.stack(table["action"])
    assert actions.shape[1] == 4 and np.abs(actions).max() <= 1.0
    return out


def test_benchmark_dataset_loads_in_lerobot_replays_and_stats_report_task_success(
    project: Path, tmp_path: Path
) -> None:
    out = _record_bench(project, tmp_path, "metaworld_pick_place_bench", 2)
    grab = pq.read_table(sorted((out / "data").rglob("*.parquet"))[0], columns=["action"]).column("action")
    assert {row[3] for row in grab.to_pylist()} == {0.0, 1.0}  # the expert opened and closed the gripper
    replay_reproduces(out, tmp_path / "replay", episodes=2)
    (group,) = stats_groups(out)
    assert group["task"] == "Pick and place a puck to a goal" and group["successes"] == group["episodes"] == 2
    assert group["success_rate"] == 1.0 and 0.3 < group["ci95_low"] < 0.4 and group["ci95_high"] == 1.0  # Wilson


@pytest.mark.slow
def test_five_benchmark_tasks_record_expert_datasets_and_stats_report_each(project: Path, tmp_path: Path) -> None:
    outs = [_record_bench(project, tmp_path, f"{scene_id}_bench", 2) for scene_id in TASKS[1:]]
    groups = {g["task"]: g for g in stats_groups(*outs)}
    assert len(groups) == 5
    for group in groups.values():
        assert group["episodes"] == 2 and group["success_rate"] == 1.0 and group["ci95_low"] < 1.0


def test_scene_errors_name_the_file_and_field(project: Path, tmp_path: Path) -> None:
    src = small_scene_file(project, "metaworld_pick_place", size=32)
    text = src.read_text()
    out = tmp_path / "o"
    src.write_text(text.replace("pick-place-v3", "pick-plaice-v3"))
    with pytest.raises(ConfigError, match=r"metaworld_pick_place\.yaml: scene\.params\.task: unknown MetaWorld"):
        record(RecordOptions(scene=str(src), rskill="metaworld-expert", out=out))
    src.write_text(text.replace("fps: 80", "fps: 20"))
    with pytest.raises(ConfigError, match=r"scene\.fps: MetaWorld steps at 80 Hz .*set fps: 80"):
        record(RecordOptions(scene=str(src), rskill="metaworld-expert", out=out))
    src.write_text(text.replace("corner2", "corner9"))
    with pytest.raises(ConfigError, match=r"scene\.cameras\[0\]\.name: no camera 'corner9' .*valid: topview, corner"):
        record(RecordOptions(scene=str(src), rskill="metaworld-expert", out=out))
    with pytest.raises(ConfigError, match=r"scene\.fixed_robot: this scene is defined for robot 'metaworld_sawyer'"):
        record(RecordOptions(scene="metaworld_pick_place_bench", rskill="metaworld-expert", robot="sawyer", out=out))
    assert not out.exists()


def test_task_records_another_metaworld_task(project: Path, tmp_path: Path) -> None:
    """`record --scene metaworld_push --task pick-place-v3`: the task string, the placement and the expert's
    actions are pick-place's; the stored scene config (what a replay rebuilds) names it; an unknown id is one line."""
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    from openral_data.replay.recorded import RecordedDataset
    from tests.support.cli import run_cli

    scene = small_scene_file(project, "metaworld_push", size=32)
    runs: dict[str, Path] = {}
    for name, extra in (("push", []), ("pick", ["--task", "pick-place-v3"])):
        out = runs[name] = tmp_path / name
        args = ["--n-episodes", "1", "--max-steps", "6", "--seed", "3", "--codec", "h264", *extra]
        done = run_cli("record", "--scene", str(scene), "--out", str(out), *args)
        assert done.returncode == 0, done.stderr
    tasks = {
        name: LeRobotDataset(f"local/{name}", root=out, video_backend="pyav")[0]["task"] for name, out in runs.items()
    }
    assert tasks == {"push": "Push the puck to a goal", "pick": "Pick and place a puck to a goal"}
    episodes = {name: RecordedDataset(out).episode(0) for name, out in runs.items()}
    push, pick = episodes["push"], episodes["pick"]
    assert (push.initial_state or {})["task"] == "push-v3" and (pick.initial_state or {})["task"] == "pick-place-v3"
    assert (push.initial_state or {})["rand_vec"] != (pick.initial_state or {})["rand_vec"]  # another placement
    assert not np.array_equal(push.actions, pick.actions)  # the pick-place expert drove it
    options = json.loads((runs["pick"] / ".openral/record.json").read_text())["options"]
    assert options["task"] == "pick-place-v3" and options["instruction"] is None
    scene_config = RecordedDataset(runs["pick"]).scene()
    assert scene_config.scene.params["task"] == "pick-place-v3"
    assert scene_config.task.instruction == "Pick and place a puck to a goal"

    bad = run_cli("record", "--scene", str(scene), "--out", str(tmp_path / "bad"), "--task", "pick-plaice-v3")
    assert bad.returncode == 2 and not (tmp_path / "bad").exists()
    line = bad.stderr.strip()
    assert "\n" not in line
    assert line == (
        "error: --task: unknown task 'pick-plaice-v3' of scene metaworld_push; did you mean 'pick-place-v3'? "
        f"({len(task_names())} in all: openral-data list tasks metaworld_push)"
    )
