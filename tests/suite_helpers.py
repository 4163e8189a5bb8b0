"""Helpers for the benchmark-suite scene tests (robosuite, MetaWorld): shipped scenes with chosen cameras,
camera projection for the upright checks, and expert/random rollouts without cameras."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
import yaml
from conftest import write_yaml

from openral_data.record import registry
from openral_data.schemas.scene import SceneCamera, SimScene, load_recordable_scene
from openral_data.types import Observation, SimRollout


def shipped(scene_id: str, cameras: list[tuple[str, int]] | None = None) -> SimScene:
    """A shipped scene with its cameras replaced (name, square size); no cameras by default."""
    scene = load_recordable_scene(registry.resolve_scene_path(scene_id))
    cams = [SceneCamera(name=n, width=s, height=s) for n, s in (cameras or [])]
    return scene.model_copy(update={"scene": scene.scene.model_copy(update={"cameras": cams})})


def build(scene_id: str, rskill_id: str, cameras: list[tuple[str, int]] | None = None) -> tuple[SimRollout, Any]:
    scene = shipped(scene_id, cameras)
    rskill = registry.resolve_rskill(rskill_id)[0]
    assert scene.scene.robot is not None
    env = registry.SCENES[scene.scene.type](scene, registry.ROBOTS[scene.scene.robot], rskill, scene_id)
    return env, registry.POLICIES[rskill.policy](rskill)


def rollout(
    env: SimRollout, policy: Any, obs: Observation, steps: int, actions: list[Any] | None = None
) -> dict[str, Any]:
    """Step `steps` times from `obs` (the policy's actions, or the given ones); states, actions, rewards, successes."""
    states, acts, rewards, successes = [obs.state], [], [], []
    for t in range(steps):
        action = policy.step(obs, obs.task) if actions is None else actions[t]
        result = env.step(action)
        obs = result.observation
        states.append(obs.state)
        acts.append(action)
        rewards.append(result.reward)
        successes.append(result.success)
        if result.terminated:
            break
    return {"states": np.stack(states), "actions": acts, "rewards": rewards, "successes": successes}


def small_scene_file(project: Path, scene_id: str, size: int = 48, **task: Any) -> Path:
    """Copy a shipped scene YAML into the test project with small cameras (and task overrides)."""
    src = registry.resolve_scene_path(scene_id)
    data = yaml.safe_load(src.read_text())
    for cam in data["scene"]["cameras"]:
        cam["width"] = cam["height"] = size
    data["task"].update(task)
    return write_yaml(project / "scenes" / src.parent.name / f"small_{scene_id}.yaml", data)


def project_point(
    model: Any, data: Any, camera: str, point: npt.NDArray[np.float64], height: int, width: int
) -> tuple[int, int]:
    """Pixel (row, col) of a world point in an *upright* image of a MuJoCo camera (pinhole, fovy).

    Upright means world "up" is image "up": in the camera's own frame (x right, y up, z backwards) MuJoCo
    renders y up; a camera whose y axis points down in the world is shown turned 180 degrees.
    """
    cam = model.camera(camera).id
    rot = data.cam_xmat[cam].reshape(3, 3)
    v = rot.T @ (np.asarray(point) - data.cam_xpos[cam])
    f = (height / 2) / np.tan(np.deg2rad(model.cam_fovy[cam]) / 2)
    col = width / 2 + f * v[0] / -v[2]
    row = height / 2 - f * v[1] / -v[2]
    if rot[2, 1] < 0:  # camera upside down in the world
        row, col = height - 1 - row, width - 1 - col
    return int(np.rint(row)), int(np.rint(col))


def replay_reproduces(dataset: Path, out: Path, episodes: int) -> dict[str, Any]:
    """`openral-data replay DATASET` (actions mode, the real CLI in a subprocess) reproduces every episode bit for
    bit (restored start and every replayed state equal the recorded ones) with the recorded outcome."""
    import pyarrow.parquet as pq
    from conftest import run_cli

    from openral_data.formats.results import open_results

    proc = run_cli("replay", str(dataset), "--out", str(out))
    assert proc.returncode == 0, proc.stderr[-3000:]
    res = open_results(out)
    assert res.summary["kind"] == "replay" and res.summary["mode"] == "actions"
    assert res.summary["reproduced"] == episodes and res.summary["success_agree"] == episodes
    table = pq.read_table(res.episodes_path).to_pydict()
    assert table["episode_index"] == list(range(episodes))
    assert max(table["divergence_max"]) == 0.0
    return res.summary


def stats_groups(*datasets: Path, by: str = "task") -> list[dict[str, Any]]:
    """`openral-data stats --by BY --format json` (the real CLI): the groups table."""
    import json

    from conftest import run_cli

    proc = run_cli("stats", *map(str, datasets), "--by", by, "--format", "json", "--no-health")
    assert proc.returncode == 0, proc.stderr[-3000:]
    groups: list[dict[str, Any]] = json.loads(proc.stdout)["groups"]
    return groups
