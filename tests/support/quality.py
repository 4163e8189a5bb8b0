"""Hand-built episodes for the quality measures: each episode's state (3 joints), action (2 joints and a
`gripper`) and one 32x32 camera given frame by frame, written through our writer (fps 10).

`moving(n, seed)` is a clean demonstration: every dimension a sinusoid of its own phase (some dimension always
moving), the gripper closing once and opening once, the camera textured noise that changes every frame."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from openral_data.formats.lerobot_v3 import LeRobotV3Writer
from openral_data.runtime.bridge import DatasetBridge
from openral_data.types import CameraShape, DatasetSchema, Observation

FPS = 10
SIDE = 32
SCHEMA = DatasetSchema(
    fps=FPS,
    state_names=("j0", "j1", "j2"),
    action_names=("a0", "a1", "gripper"),
    cameras={"cam": CameraShape(SIDE, SIDE)},
    robot_type="unit",
)


@dataclass
class Episode:
    state: np.ndarray  # (n, 3)
    action: np.ndarray  # (n, 3)
    images: np.ndarray  # (n, SIDE, SIDE, 3) uint8


def textured(n: int, seed: int) -> np.ndarray:
    return np.random.default_rng(seed).integers(40, 216, (n, SIDE, SIDE, 3), dtype=np.uint8)


def moving(n: int, seed: int = 0, period_s: float = 4.0) -> Episode:
    rng = np.random.default_rng(seed)
    t = np.arange(n)[:, None] / FPS
    phase = rng.uniform(0, 2 * np.pi) + np.array([0.0, 2 * np.pi / 3, 4 * np.pi / 3])
    wave = np.sin(2 * np.pi * t / period_s + phase).astype(np.float32)
    grip = np.where((np.arange(n) >= n // 3) & (np.arange(n) < 2 * n // 3), 1.0, 0.0).astype(np.float32)
    action = np.concatenate([wave[:, :2] * 0.8, grip[:, None]], axis=1)
    return Episode(wave.copy(), action, textured(n, seed))


def write(root: Path, episodes: list[Episode]) -> Path:
    writer = LeRobotV3Writer(root, SCHEMA)
    bridge = DatasetBridge(SCHEMA, [writer])
    for e, ep in enumerate(episodes):
        n = len(ep.state)
        bridge.begin_episode(seed=e, initial_state={})
        for t in range(n):
            obs = Observation(images={"cam": ep.images[t]}, state=ep.state[t], task="task")
            bridge.add_step(obs, ep.action[t], reward=0.0, done=t == n - 1, success=t == n - 1)
        bridge.end_episode(success=True)
    bridge.close()
    return root


def idle_middle(root: Path, n: int = 40) -> Path:
    """Three moving episodes of `n` frames, the middle one idle for its first 3/4 (then off at full speed)."""
    eps = [moving(n, s) for s in range(3)]
    still = 3 * n // 4
    eps[1].state[:still] = eps[1].state[still - 1]
    eps[1].action[:still] = eps[1].action[still - 1]
    return write(root, eps)
