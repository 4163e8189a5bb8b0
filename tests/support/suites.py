"""Helpers for the benchmark-suite adapter tests (gym-pusht, gym-aloha, LIBERO): build a shipped scene with
chosen cameras/params, roll a policy, compare rollouts, check a recorded dataset with lerobot 0.6.1."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from openral_data.record import registry
from openral_data.schemas.scene import SceneCamera, SimScene, load_recordable_scene
from openral_data.types import SimRollout


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
    rskill = registry.resolve_rskill(rskill_id)[0]
    policy = registry.POLICIES[rskill.policy](rskill)
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
    import json

    from openral_data.metrics.command import StatsOptions, run_stats

    report = json.loads(run_stats(StatsOptions([str(dataset)], by="task", fmt="json")))
    assert report["health"] == []
    (group,) = report["groups"]
    assert group["success_known"] == group["episodes"]
    assert 0.0 <= group["ci95_low"] <= group["success_rate"] <= group["ci95_high"] <= 1.0
    assert group["ci95_high"] > group["ci95_low"]
    return dict(group)
