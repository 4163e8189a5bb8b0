"""Helpers for the benchmark-suite scene tests (gym-pusht, gym-aloha, LIBERO, robosuite, MetaWorld): build a shipped
scene with chosen cameras/params, roll a policy or given actions, compare rollouts, project points into upright
camera images, check a recorded dataset with lerobot 0.6.1, and replay / stats through the real CLI."""

from __future__ import annotations

import json
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
import pyarrow.parquet as pq
import yaml

from openral_data.formats.results import open_results
from openral_data.runtime import registry
from openral_data.schemas.scene import SceneCamera, SimScene, load_recordable_scene
from openral_data.types import Observation, SimRollout
from tests.support.cli import run_cli
from tests.support.scenes import write_yaml


def shipped(scene_id: str, cameras: list[tuple[str, int, int]] | None = None, **params: Any) -> SimScene:
    scene = load_recordable_scene(registry.resolve_scene_path(scene_id))
    update: dict[str, Any] = {"params": {**scene.scene.params, **params}}
    if cameras is not None:
        update["cameras"] = [SceneCamera(name=n, width=w, height=h) for n, w, h in cameras]
    return scene.model_copy(update={"scene": scene.scene.model_copy(update=update)})


def build(scene: SimScene, rskill_id: str) -> SimRollout:
    rskill = registry.resolve_rskill(rskill_id)[0]
    robot = registry.ROBOTS[scene.scene.robot or ""]
    return registry.SCENES[scene.scene.type](scene, robot, rskill, f"scene {scene.scene.id}")


def make_policy(rskill_id: str) -> Any:
    rskill = registry.resolve_rskill(rskill_id)[0]
    return registry.POLICIES[rskill.policy](rskill)


def env_and_policy(
    scene_id: str, rskill_id: str, cameras: list[tuple[str, int, int]] | None = None
) -> tuple[SimRollout, Any]:
    """A shipped scene (no cameras unless given) built for an rSkill, and that rSkill's policy."""
    return build(shipped(scene_id, cameras or []), rskill_id), make_policy(rskill_id)


Rollout = tuple[list[npt.NDArray[Any]], list[npt.NDArray[Any]], list[float], list[float | None]]


def roll(env: SimRollout, actions: list[npt.NDArray[np.float32]], first: Any) -> Rollout:
    """States, images (first camera, if any), rewards and times after `first` (an Observation) and each action."""
    states, images, rewards, times = [first.state], [], [], [first.time]
    if first.images:
        images.append(next(iter(first.images.values())))
    for a in actions:
        r = env.step(a)
        states.append(r.observation.state)
        rewards.append(r.reward)
        times.append(r.observation.time)
        if r.observation.images:
            images.append(next(iter(r.observation.images.values())))
    return states, images, rewards, times


def random_actions(rskill_id: str, n: int, seed: int) -> list[npt.NDArray[np.float32]]:
    policy = make_policy(rskill_id)
    policy.reset(seed)
    return [policy.step(None, "") for _ in range(n)]  # type: ignore[arg-type]


def assert_same(a: Rollout, b: Rollout) -> None:
    assert len(a[0]) == len(b[0])
    for x, y in zip(a[0], b[0], strict=True):
        assert np.array_equal(x, y)
    for x, y in zip(a[1], b[1], strict=True):
        assert np.array_equal(x, y)
    assert a[2] == b[2] and a[3] == b[3]


def lerobot_table(root: Path) -> tuple[Any, dict[str, Any]]:
    """lerobot 0.6.1's LeRobotDataset on `root` and its frame table as numpy columns."""
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    ds = LeRobotDataset("local/check", root=root, video_backend="pyav")
    table = ds.hf_dataset.with_format("numpy")
    cols = {k: np.asarray(table[k]) for k in ("episode_index", "frame_index", "next.success", "next.reward")}
    cols["observation.state"] = np.stack(table["observation.state"])
    cols["action"] = np.stack(table["action"])
    return ds, cols


def stats_per_task(dataset: Path) -> dict[str, Any]:
    """`openral-data stats --by task` on a recorded dataset: one group, its success rate and Wilson interval,
    no health issue."""
    from openral_data.metrics.command import StatsOptions, run_stats

    report = json.loads(run_stats(StatsOptions([str(dataset)], by="task", fmt="json")))
    assert report["health"] == []
    (group,) = report["groups"]
    assert group["success_known"] == group["episodes"]
    assert 0.0 <= group["ci95_low"] <= group["success_rate"] <= group["ci95_high"] <= 1.0
    assert group["ci95_high"] > group["ci95_low"]
    return dict(group)


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


def replay_reproduces(dataset: Path, out: Path, episodes: int) -> Mapping[str, object]:
    """`openral-data replay DATASET` (actions mode, the real CLI in a subprocess) reproduces every episode bit for
    bit (restored start and every replayed state equal the recorded ones) with the recorded outcome."""

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

    proc = run_cli("stats", *map(str, datasets), "--by", by, "--format", "json", "--no-health")
    assert proc.returncode == 0, proc.stderr[-3000:]
    groups: list[dict[str, Any]] = json.loads(proc.stdout)["groups"]
    return groups
