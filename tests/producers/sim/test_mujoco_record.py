"""Record the MuJoCo tabletop scenes end to end and open the result with lerobot 0.6.1's loader."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest
import yaml

from openral_data.record.options import RecordOptions
from openral_data.record.sim import record
from openral_data.runtime import registry
from tests.support.cli import run_cli
from tests.support.mujoco import expert_rskill, red_mask, shipped_scene
from tests.support.scenes import write_yaml


def _small_scene(project: Path, kind: str, size: int = 64, **scene_over: object) -> Path:
    data = yaml.safe_load((project / f"scenes/sim/tabletop_{kind}.yaml").read_text())
    for cam in data["scene"]["cameras"]:
        cam["width"] = cam["height"] = size
    data["scene"].update(scene_over)
    return write_yaml(project / f"scenes/sim/small_{kind}.yaml", data)


def _expert_rollout(kind: str, seed: int, max_steps: int) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """States and actions of the expert on a camera-less copy of the scene (physics does not depend on cameras)."""
    from openral_data.producers.sim.mujoco.scene import TabletopScene

    rskill = expert_rskill(kind)
    scene = TabletopScene(shipped_scene(kind), registry.ROBOTS["franka_panda"], rskill, kind)  # type: ignore[arg-type]
    policy = registry.POLICIES[rskill.policy](rskill)
    states, actions = [], []
    try:
        obs = scene.reset(seed)
        policy.reset(seed)
        for _ in range(max_steps):
            action = policy.step(obs, obs.task)
            states.append(obs.state)
            actions.append(action)
            result = scene.step(action)
            obs = result.observation
            if result.terminated:
                break
    finally:
        scene.close()
    return states, actions


def test_recorded_push_dataset_loads_in_lerobot_and_holds_what_the_expert_did(project: Path, tmp_path: Path) -> None:
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    scene = _small_scene(project, "push")
    out = tmp_path / "push"
    summary = record(RecordOptions(scene=str(scene), rskill="scripted-push", n_episodes=2, seed=5, out=out))
    assert summary.success_rate == 1.0

    ds = LeRobotDataset("local/push", root=out, video_backend="pyav")
    assert len(ds) == summary.frames
    assert ds.meta.video_keys == [
        "observation.images.front",
        "observation.images.overhead",
        "observation.images.wrist",
    ]
    assert ds.meta.robot_type == "franka_panda"
    # row for row, the dataset holds exactly the states the scene produced and the actions the expert emitted
    states, actions = _expert_rollout("push", 5, 250)
    table = ds.hf_dataset.with_format("numpy")
    first = np.flatnonzero(np.asarray(table["episode_index"]) == 0)
    assert len(first) == len(actions)
    assert np.array_equal(np.stack(table["observation.state"])[first].astype(np.float32), np.stack(states))
    assert np.array_equal(np.stack(table["action"])[first].astype(np.float32), np.stack(actions))
    # decoded video shows the scene: red cube in the front and overhead views, frames change over the episode
    start, end = ds[0], ds[len(first) - 1]
    for key in ("observation.images.front", "observation.images.overhead"):
        img = (start[key].numpy().transpose(1, 2, 0) * 255).astype(np.uint8)
        assert red_mask(img).sum() >= 3, key
        assert img.std() > 10
        last = (end[key].numpy().transpose(1, 2, 0) * 255).astype(np.uint8)
        assert np.abs(last.astype(int) - img.astype(int)).mean() > 1  # the arm moved, the cube moved
    assert float(end["next.success"]) == 1.0
    episodes = ds.meta.episodes
    initial = json.loads(episodes["openral.initial_state"][0])
    assert initial["seed"] == 5 and initial["task"] == "push"


def test_robot_override_on_free_scene_and_refusal_on_fixed_scene(project: Path, tmp_path: Path) -> None:
    scene = _small_scene(project, "pick_place", size=32)
    out = tmp_path / "ur5e"
    proc = run_cli(
        "record", "--scene", str(scene), "--rskill", "scripted-pick-place", "--robot", "ur5e",
        "--n-episodes", "1", "--max-steps", "4", "--out", str(out), "--codec", "h264",
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    info = json.loads((out / "meta/info.json").read_text())
    assert info["robot_type"] == "ur5e" and info["total_frames"] == 4

    bench = project / "scenes/benchmark/tabletop_push_bench.yaml"
    proc = run_cli("record", "--scene", str(bench), "--rskill", "scripted-push", "--robot", "ur5e",
                   "--out", str(tmp_path / "no"))  # fmt: skip
    assert proc.returncode == 2
    lines = [ln for ln in proc.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and re.search(
        r"tabletop_push_bench\.yaml: scene\.fixed_robot: this scene is defined for robot 'franka_panda' only", lines[0]
    ), proc.stderr
    assert not (tmp_path / "no").exists()


def test_bad_robot_wiring_is_one_line_naming_file_and_field(project: Path, tmp_path: Path) -> None:
    path = project / "robots/franka_panda/robot.yaml"
    data = yaml.safe_load(path.read_text())
    data["sim"]["arm_joints"][2] = "elbow_of_doom"
    write_yaml(path, data)
    scene = _small_scene(project, "push", size=32)
    proc = run_cli("record", "--scene", str(scene), "--rskill", "scripted-push", "--out", str(tmp_path / "o"))
    lines = [ln for ln in proc.stderr.splitlines() if ln.strip()]
    assert proc.returncode == 2 and len(lines) == 1, proc.stderr
    assert re.search(r"franka_panda/robot\.yaml: sim\.arm_joints\[2\]: no joint 'elbow_of_doom'", lines[0])
    data["sim"]["kp"] = [1.0]
    write_yaml(path, data)
    proc = run_cli("record", "--scene", str(scene), "--rskill", "scripted-push", "--out", str(tmp_path / "o"))
    assert proc.returncode == 2 and re.search(r"robot\.yaml: sim: .*kp needs one value per arm joint", proc.stderr)


@pytest.mark.slow
def test_recorded_pick_place_dataset_loads_with_a_gripper_that_matters(project: Path, tmp_path: Path) -> None:
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    scene = _small_scene(project, "pick_place")
    out = tmp_path / "pp"
    summary = record(RecordOptions(scene=str(scene), rskill="scripted-pick-place", n_episodes=3, out=out))
    assert summary.success_rate == 1.0
    ds = LeRobotDataset("local/pp", root=out, video_backend="pyav")
    table = ds.hf_dataset.with_format("numpy")
    actions, states = np.stack(table["action"]), np.stack(table["observation.state"])
    assert set(np.unique(actions[:, 6]).tolist()) == {0.0, 1.0}  # the gripper opened and closed
    assert states[:, 7].max() > 0.3 and states[:, 7].min() < 0.05  # fingers closed on the cube (not fully)


def test_a_scene_without_rskill_records_with_its_default_and_a_misfit_lists_what_fits(tmp_path: Path) -> None:
    """`record --scene tabletop_push` needs no --rskill (the scene suggests scripted-push); a pairing that does not
    fit is refused with the rSkills that do."""
    out = tmp_path / "o"
    done = run_cli("record", "--scene", "tabletop_push", "--n-episodes", "1", "--max-steps", "4", "--codec", "h264",
                   "--out", str(out))  # fmt: skip
    assert done.returncode == 0, done.stderr
    saved = json.loads((out / ".openral" / "record.json").read_text())["options"]
    assert Path(saved["rskill"]).parent.name == "scripted-push"
    refused = run_cli("record", "--scene", "tabletop_push", "--rskill", "random-mock", "--out", str(tmp_path / "x"))
    assert refused.returncode == 2
    assert re.search(
        r"embodiment_tags: .*\(rSkills that fit: [^)]*scripted-pick-place, [^)]*scripted-push[,)]", refused.stderr
    )
    assert not (tmp_path / "x").exists()
