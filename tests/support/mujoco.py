"""Helpers for the MuJoCo scene tests: build a scene from the shipped YAMLs with chosen cameras/robot."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
import pytest
import yaml

from openral_data.errors import ConfigError
from openral_data.producers.sim.mujoco.assets import check_robosuite_assets
from openral_data.producers.sim.mujoco.scene import TabletopScene
from openral_data.record.options import RecordOptions
from openral_data.record.sim import record
from openral_data.runtime import registry
from openral_data.schemas.rskill import Contract, RSkillManifest
from openral_data.schemas.scene import RenderConfig, SceneCamera, SimScene, load_recordable_scene
from tests.support.scenes import write_yaml

try:
    check_robosuite_assets("tests")
except ConfigError as exc:  # the LIBERO environment (robosuite 1.4): these tests belong to the default one
    pytest.skip(str(exc), allow_module_level=True)

RED_MIN, OTHER_MAX = 120, 80  # a pixel of the red cube: R high, G and B low

FRONT = SceneCamera(name="front", width=96, height=96, pos=(1.2, 0.0, 1.3), lookat=(0.42, 0.0, 0.85), fovy=45)
OVERHEAD = SceneCamera(name="overhead", width=96, height=96, pos=(0.85, 0.0, 1.9), lookat=(0.52, 0.0, 0.8), fovy=45)
WRIST = SceneCamera(name="wrist", width=64, height=64, mount="wrist")


def shipped_scene(
    kind: str,
    cameras: list[SceneCamera] | None = None,
    render: RenderConfig | None = None,
    params: dict[str, Any] | None = None,
    **task: Any,
) -> SimScene:
    scene = load_recordable_scene(registry.resolve_scene_path(f"tabletop_{kind}"))
    update: dict[str, Any] = {"cameras": cameras if cameras is not None else [], "render": render or scene.scene.render}
    if params is not None:
        update["params"] = {**scene.scene.params, **params}
    spec = scene.scene.model_copy(update=update)
    return scene.model_copy(update={"scene": spec, "task": scene.task.model_copy(update=task)})


def expert_rskill(kind: str) -> RSkillManifest:
    return registry.resolve_rskill(f"scripted-{kind.replace('_', '-')}")[0]


def joint_rskill(n_joints: int) -> RSkillManifest:
    names = [f"q{k}" for k in range(n_joints)] + ["gripper"]
    contract = Contract(dim=n_joints + 1, names=names, representation="joint_positions_gripper")
    return RSkillManifest(
        id="joint-test",
        policy="zero",
        embodiment_tags=["single_arm"],
        state_contract=contract,
        action_contract=contract,
    )


def make_scene(
    kind: str = "push", robot: str = "franka_panda", cameras: list[SceneCamera] | None = None, **kw: Any
) -> TabletopScene:
    rskill = kw.pop("rskill", None) or expert_rskill(kind)
    scene = shipped_scene(kind, cameras, kw.pop("render", None), kw.pop("params", None))
    return TabletopScene(scene, registry.ROBOTS[robot], rskill, kind)  # type: ignore[arg-type]


def layout_scene(
    params: dict[str, Any], robot: str = "franka_panda", cameras: list[SceneCamera] | None = None
) -> TabletopScene:
    """A `type: tabletop` scene (the shipped push scene's robot placement, cameras as given) with `params` as its
    objects, workspace, clutter and success; driven by the scripted-push rSkill's contracts."""
    base = shipped_scene("push", cameras)
    spec = base.scene.model_copy(update={"type": "tabletop", "params": params})
    scene = base.model_copy(update={"scene": spec})
    return registry.SCENES["tabletop"](scene, registry.ROBOTS[robot], expert_rskill("push"), "test.yaml")  # type: ignore[return-value]


def run_expert(scene: TabletopScene, seed: int, max_steps: int) -> tuple[bool, int]:
    policy = registry.POLICIES[f"scripted_{scene.task_kind}"](expert_rskill(scene.task_kind))
    obs = scene.reset(seed)
    policy.reset(seed)
    for t in range(max_steps):
        result = scene.step(policy.step(obs, obs.task))
        obs = result.observation
        if result.terminated:
            return result.success, t + 1
    return False, max_steps


def red_mask(img: npt.NDArray[np.uint8]) -> npt.NDArray[np.bool_]:
    r, g, b = (img[..., k].astype(np.int32) for k in range(3))
    return (r >= RED_MIN) & (g <= OTHER_MAX) & (b <= OTHER_MAX)


def project(scene: TabletopScene, camera: str, point: npt.NDArray[np.float64]) -> tuple[float, float]:
    """Pixel (column, row) where a world point appears in a camera, from MuJoCo's camera pose and fovy."""
    m, d = scene.model, scene.data
    cid = m.camera(camera).id
    pos, rot = d.cam_xpos[cid], d.cam_xmat[cid].reshape(3, 3)
    local = rot.T @ (point - pos)
    cam = next(c for c in scene.spec.cameras if c == camera)
    shape = scene.spec.cameras[cam]
    f = (shape.height / 2) / np.tan(np.deg2rad(m.cam_fovy[cid]) / 2)
    return shape.width / 2 + f * local[0] / -local[2], shape.height / 2 - f * local[1] / -local[2]


@dataclass
class PushRecording:
    out: Path
    scene_file: Path
    actions: npt.NDArray[np.float32]  # as lerobot loads them: what a second rollout of the episode replays


def record_push_variant(
    home: Path, name: str, scene: dict[str, Any], seed: int, steps: int, out: Path
) -> PushRecording:
    """One episode of the shipped `tabletop_push` (in the isolated `home`) with the `scene:` keys in `scene`
    replaced (cameras, observations), saved as scene `name` and recorded by the push expert to LeRobot v3 and
    MCAP at `out`."""
    data = yaml.safe_load((home / "scenes/sim/tabletop_push.yaml").read_text())
    data["scene"].update(scene)
    scene_file = write_yaml(home / f"scenes/sim/{name}.yaml", data)
    opts = RecordOptions(
        scene=str(scene_file), n_episodes=1, seed=seed, max_steps=steps, out=out, formats=("lerobot", "mcap")
    )
    assert record(opts).frames == steps
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    ds = LeRobotDataset(f"local/{name}", root=out, video_backend="pyav")
    actions = np.stack(ds.hf_dataset.with_format("numpy")["action"]).astype(np.float32)
    return PushRecording(out, scene_file, actions)


def push_scene(scene_file: Path) -> TabletopScene:
    """The push scene of `scene_file` on the Franka, driven by the push expert's contract."""
    return TabletopScene(
        load_recordable_scene(scene_file), registry.ROBOTS["franka_panda"], expert_rskill("push"), "push"
    )
