"""The scripted experts of the YAML-declared tabletop tasks (stack, place-on, open-drawer, pick-from-clutter) reach
their scene's success criterion in real MuJoCo, driving the arm through the delta_eef_gripper IK controller."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from openral_data.errors import ConfigError
from openral_data.policies.scripted import ScriptedOpenDrawer, ScriptedPickPlace
from openral_data.producers.sim.mujoco.scene import TabletopScene
from openral_data.runtime import registry
from openral_data.types import Observation
from tests.support.cli import run_cli
from tests.support.mujoco import shipped_scene

TASKS = {"stack": "scripted-stack", "place_on": "scripted-place-on", "open_drawer": "scripted-open-drawer",
         "pick_clutter": "scripted-pick"}  # fmt: skip


def _rollout(kind: str, robot: str, seed: int) -> tuple[bool, TabletopScene, Observation]:
    """The scene's default expert on a camera-less `tabletop_<kind>` (physics does not depend on cameras)."""
    cfg = shipped_scene(kind)
    assert cfg.scene.default_rskill == TASKS[kind]
    rskill = registry.resolve_rskill(TASKS[kind])[0]
    scene = TabletopScene(cfg, registry.ROBOTS[robot], rskill, None)  # type: ignore[arg-type]
    policy = registry.POLICIES[rskill.policy](rskill)
    try:
        obs = scene.reset(seed)
        policy.reset(seed)
        for _ in range(cfg.task.max_steps):
            result = scene.step(policy.step(obs, obs.task))
            obs = result.observation
            if result.terminated:
                return result.success, scene, obs
        return False, scene, obs
    finally:
        scene.close()


def _on(obs: Observation, top: str, bottom: str) -> bool:
    """`top` rests on `bottom`: centred within its footprint, at its top height (read from ground truth)."""
    a, b = obs.privileged["objects"][top], obs.privileged["objects"][bottom]
    return bool(
        np.linalg.norm(np.asarray(a["pos"][:2]) - b["pos"][:2]) < b["size"][0] / 2
        and abs(a["pos"][2] - a["bottom"] - b["top_z"]) < 0.01
    )


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_stack_puts_the_red_cube_on_the_green_one(seed: int) -> None:
    ok, _, obs = _rollout("stack", "franka_panda", seed)
    assert ok and _on(obs, "red", "green")


@pytest.mark.parametrize("seed", [0, 1])
def test_place_on_puts_the_can_on_the_box(seed: int) -> None:
    ok, _, obs = _rollout("place_on", "franka_panda", seed)
    assert ok and _on(obs, "can", "box")


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_open_drawer_pulls_the_drawer_open_by_the_distance(seed: int) -> None:
    ok, _, obs = _rollout("open_drawer", "franka_panda", seed)
    drawer = obs.privileged["objects"]["drawer"]
    assert ok and 0.12 <= drawer["opening"] <= drawer["max_opening"] + 1e-3


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_pick_from_clutter_lifts_the_target_and_only_it(seed: int) -> None:
    ok, scene, obs = _rollout("pick_clutter", "franka_panda", seed)
    objects = obs.privileged["objects"]
    clutter = [name for name in objects if name.startswith("clutter_")]
    assert ok and len(clutter) == 5
    target = objects["target"]
    assert target["pos"][2] - target["bottom"] - scene.table_height >= 0.1
    for name in clutter:  # nothing else left the table
        info = objects[name]
        assert info["pos"][2] - info["bottom"] - scene.table_height < 0.02, name


@pytest.mark.parametrize(("kind", "robot"), [("stack", "ur5e"), ("open_drawer", "iiwa")])
def test_another_arm_runs_the_same_experts(kind: str, robot: str) -> None:
    assert _rollout(kind, robot, 0)[0]


def test_experts_name_a_missing_role() -> None:
    """A scene without the role an expert needs is a one-line ConfigError, not a KeyError."""
    cfg = shipped_scene("open_drawer")
    rskill = registry.resolve_rskill("scripted-open-drawer")[0]
    scene = TabletopScene(cfg, registry.ROBOTS["franka_panda"], rskill, None)  # type: ignore[arg-type]
    try:
        obs = scene.reset(0)
    finally:
        scene.close()
    with pytest.raises(ConfigError, match="role 'object'"):
        ScriptedPickPlace(rskill).step(obs, "")
    obs.privileged["roles"] = {}
    with pytest.raises(ConfigError, match="role 'drawer'"):
        ScriptedOpenDrawer(rskill).step(obs, "")


@pytest.mark.slow
def test_record_open_drawer_works_out_of_the_box(tmp_path: Path) -> None:
    """`record --scene tabletop_open_drawer` needs no --rskill: the scene's default expert records a success."""
    out = tmp_path / "o"
    done = run_cli("record", "--scene", "tabletop_open_drawer", "--n-episodes", "1", "--codec", "h264",
                   "--out", str(out))  # fmt: skip
    assert done.returncode == 0, done.stderr
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    ds = LeRobotDataset("local/o", root=out, video_backend="pyav")
    assert ds.num_episodes == 1 and 30 < ds.num_frames < 250
    assert bool(np.asarray(ds.hf_dataset.with_format("numpy")["next.success"])[-1])
