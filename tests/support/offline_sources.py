"""Small offline-RL and simulator-trajectory sources in the layouts `convert` reads; every value a function of
(episode, step) so tests can recompute it:

* D4RL (`Farama-Foundation/D4RL:d4rl/offline_env.py` `get_dataset` reads,
  `Farama-Foundation/D4RL:scripts/generation/*` write): one flat file, root `observations` (N, obs) float32,
  `actions` (N, act) float32, `rewards` (N,) float32, `terminals` / `timeouts` (N,) bool, `next_observations`,
  `infos/*` (N, ...), `metadata/*` (not per step); written with h5py here.
* Minari: written by minari itself (`minari.create_dataset_from_buffers`, its HDF5 storage) from
  `EpisodeBuffer`s, into `MINARI_DATASETS_PATH`. (Its `DataCollector` needs jax, minari's `create` extra, which
  this environment does not install; the buffers are what the collector would hold: T + 1 observations and
  infos, T actions, rewards, terminations, truncations.)
* ManiSkill (`haosulab/ManiSkill:mani_skill/utils/wrappers/record.py` at 089c82b8, `RecordEpisode.flush_trajectory`
  and `clean_trajectories`): `traj_N` groups with `actions` (T, A) float32, `terminated`, `truncated`, `success`,
  `fail` (T,) bool, `rewards` (T,) float32, `obs/agent/{qpos,qvel}`, `obs/extra/tcp_pose`,
  `obs/sensor_data/<cam>/{rgb,depth}`, `env_states/actors/<name>` (T + 1 rows), rgb and depth gzip-compressed as
  there; the `.json` beside with `env_info` (`env_id`, `env_kwargs`, `max_episode_steps`), `commit_info`,
  `episodes` (`episode_id`, `episode_seed`, `control_mode`, `elapsed_steps`, `reset_kwargs`, `success`).
  Written with h5py here (mani_skill is not installed in this environment).
"""

from __future__ import annotations

import json
import os
import warnings
from pathlib import Path
from typing import Any

import h5py
import numpy as np

CAM = 32  # Minari treats a uint8 Box of at least 32x32 as an image (is_image_space)


def obs_d4rl(row: int, width: int = 4) -> np.ndarray[Any, np.dtype[np.float32]]:
    return np.array([row * 0.5 + i * 0.25 for i in range(width)], np.float32)


def act_d4rl(row: int, width: int = 2) -> np.ndarray[Any, np.dtype[np.float32]]:
    return np.array([-row * 0.125 + i for i in range(width)], np.float32)


def write_d4rl(
    path: Path, rows: int = 11, terminals: tuple[int, ...] = (3,), timeouts: tuple[int, ...] = (7,),
    *, goal: bool = True,
) -> Path:  # fmt: skip
    """`rows` rows; episodes end after the rows in `terminals` and `timeouts` (the rest: an unfinished one);
    `goal`: an `infos/goal_achieved` that is set on each terminal row."""
    path.parent.mkdir(parents=True, exist_ok=True)
    with h5py.File(path, "w") as f:
        f["observations"] = np.stack([obs_d4rl(r) for r in range(rows)])
        f["next_observations"] = np.stack([obs_d4rl(r + 1) for r in range(rows)])
        f["actions"] = np.stack([act_d4rl(r) for r in range(rows)])
        f["rewards"] = np.arange(rows, dtype=np.float32) * 0.5
        f["terminals"] = np.isin(np.arange(rows), terminals)
        f["timeouts"] = np.isin(np.arange(rows), timeouts)
        f["infos/qpos"] = np.arange(rows * 3, dtype=np.float64).reshape(rows, 3)
        if goal:
            f["infos/goal_achieved"] = np.isin(np.arange(rows), terminals)
        f["metadata/algorithm"] = np.bytes_("SAC")
        f["metadata/policy/fc0/weight"] = np.zeros((8, 4), np.float32)  # not per step
    return path


def minari_obs(e: int, t: int) -> dict[str, np.ndarray[Any, Any]]:
    y, x = np.mgrid[0:CAM, 0:CAM]
    cam = np.stack([x * 6 + t * 9, y * 6 + e * 40, np.full_like(x, 60 + 20 * t)], axis=-1) % 256
    return {"agent": np.array([e, t * 0.5, -t], np.float32), "cam": cam.astype(np.uint8),
            "desired_goal": np.array([1.0 + e, 2.0], np.float64)}  # fmt: skip


def write_minari(root: Path, lengths: tuple[int, ...] = (4, 3), *, success: bool = True, box: bool = False) -> Path:
    """A Minari dataset `toy/reach-v0` under `root` (its MINARI_DATASETS_PATH) written by minari; returns its
    folder. Episode e's last step succeeds when `success` (infos/success after it). `box`: a Box observation (the
    agent vector alone) and a Discrete action (`t % 3`) instead of the Dict observation and Box action."""
    import gymnasium as gym
    import minari  # type: ignore[import-untyped]
    from minari.data_collector import EpisodeBuffer  # type: ignore[import-untyped]

    agent = gym.spaces.Box(-10, 10, (3,), np.float32)
    obs_space: gym.Space[Any] = agent if box else gym.spaces.Dict({
        "agent": agent,
        "cam": gym.spaces.Box(0, 255, (CAM, CAM, 3), np.uint8),
        "desired_goal": gym.spaces.Box(-5, 5, (2,), np.float64),
    })  # fmt: skip
    act_space: gym.Space[Any] = gym.spaces.Discrete(3) if box else gym.spaces.Box(-1, 1, (2,), np.float32)
    buffers = []
    for e, n in enumerate(lengths):
        frames = [minari_obs(e, t) for t in range(n + 1)]
        obs: Any = [fr["agent"] for fr in frames] if box else {k: [fr[k] for fr in frames] for k in frames[0]}
        buffers.append(EpisodeBuffer(
            id=e, seed=100 + e, observations=obs,
            actions=[t % 3 if box else np.array([0.1 * t, -0.1 * e], np.float32) for t in range(n)],
            rewards=[float(t + e) for t in range(n)], terminations=[success and t == n - 1 for t in range(n)],
            truncations=[not success and t == n - 1 for t in range(n)],
            infos={"success": [False] * n + [success]},
        ))  # fmt: skip
    old = os.environ.get("MINARI_DATASETS_PATH")
    os.environ["MINARI_DATASETS_PATH"] = str(root.resolve())  # minari joins a relative one twice
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # minari asks for an author, a code permalink... of a test dataset
            minari.create_dataset_from_buffers("toy/reach-v0", buffers, observation_space=obs_space,
                                               action_space=act_space, algorithm_name="scripted")  # fmt: skip
    finally:
        if old is None:
            os.environ.pop("MINARI_DATASETS_PATH")
        else:
            os.environ["MINARI_DATASETS_PATH"] = old
    return root / "toy" / "reach-v0"


def ms_qpos(e: int, t: int) -> np.ndarray[Any, np.dtype[np.float32]]:
    return np.array([e + 0.1 * t + 0.01 * j for j in range(9)], np.float32)


def ms_action(e: int, t: int) -> np.ndarray[Any, np.dtype[np.float32]]:
    return np.array([0.05 * t - e + 0.001 * j for j in range(8)], np.float32)


def ms_rgb(e: int, t: int) -> np.ndarray[Any, np.dtype[np.uint8]]:
    y, x = np.mgrid[0:CAM, 0:CAM]
    return (np.stack([x * 5 + t * 11, y * 5 + e * 30, np.full_like(x, 90 + 7 * t)], axis=-1) % 256).astype(np.uint8)


def write_maniskill(
    path: Path, lengths: tuple[int, ...] = (5, 3), *, control_mode: str = "pd_joint_delta_pos", cameras: bool = True
) -> Path:
    """`path` (.h5) and its .json, as RecordEpisode writes them for PickCube-v1; trajectory e succeeds from its
    last step on."""
    path.parent.mkdir(parents=True, exist_ok=True)
    episodes = []
    with h5py.File(path, "w") as f:
        for e, n in enumerate(lengths):
            g = f.create_group(f"traj_{e}", track_order=True)
            g["obs/agent/qpos"] = np.stack([ms_qpos(e, t) for t in range(n + 1)])
            g["obs/agent/qvel"] = np.stack([ms_qpos(e, t) * 2 for t in range(n + 1)])
            g["obs/extra/tcp_pose"] = np.stack([np.full(7, e + t, np.float32) for t in range(n + 1)])
            g["obs/extra/is_grasped"] = np.zeros(n + 1, bool)
            if cameras:
                g.create_dataset("obs/sensor_data/base_camera/rgb", data=np.stack([ms_rgb(e, t) for t in range(n + 1)]),
                                 compression="gzip", compression_opts=5)  # fmt: skip
                g.create_dataset("obs/sensor_data/base_camera/depth", data=np.full((n + 1, CAM, CAM, 1), 500, np.int16),
                                 compression="gzip", compression_opts=5)  # fmt: skip
                g["obs/sensor_param/base_camera/intrinsic_cv"] = np.tile(np.eye(3, dtype=np.float32), (n + 1, 1, 1))
            g["actions"] = np.stack([ms_action(e, t) for t in range(n)])
            g["terminated"] = np.arange(n) == n - 1
            g["truncated"] = np.zeros(n, bool)
            g["success"] = np.arange(n) == n - 1
            g["fail"] = np.zeros(n, bool)
            g["env_states/actors/cube"] = np.zeros((n + 1, 13), np.float32)
            g["env_states/articulations/panda"] = np.zeros((n + 1, 31), np.float32)
            g["rewards"] = np.linspace(0, 1, n, dtype=np.float32)
            episodes.append({"episode_id": e, "episode_seed": 7 + e, "control_mode": control_mode,
                             "elapsed_steps": n, "reset_kwargs": {"seed": 7 + e, "options": {}}, "success": True,
                             "fail": False})  # fmt: skip
    doc = {
        "env_info": {"env_id": "PickCube-v1", "max_episode_steps": 50,
                     "env_kwargs": {"obs_mode": "rgbd", "control_mode": control_mode, "render_mode": "rgb_array",
                                    "sim_backend": "physx_cpu", "robot_uids": "panda"}},
        "commit_info": {"commit_id": "0" * 40, "branch": "main"},
        "source_type": "motionplanning",
        "episodes": episodes,
    }  # fmt: skip
    path.with_suffix(".json").write_text(json.dumps(doc, indent=2))
    return path
