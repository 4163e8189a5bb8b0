"""A deterministic dataset written through `LeRobotV3Writer` + `DatasetBridge`, and the check that lerobot 0.6.1
loads it frame-exact.

Episode `e` of `lengths` has `lengths[e]` frames; frame `t` of it has state `episode_states(e, n, dim)[t]`
(state[0] = t, the rest drawn from a generator seeded by `e`), action `(e, t)`, and one camera `cam` whose top
quarter is the solid colour `(t, 37 e, 200)` over noise (`patterned`). Every episode is a function of its index
alone, so a dataset resumed at episode k after a crash can be written on and compared with an uninterrupted one.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np

from openral_data.formats.lerobot_v3 import LeRobotV3Writer, WriterConfig
from openral_data.runtime.bridge import DatasetBridge
from openral_data.types import CameraShape, DatasetSchema, Observation

H, W = 128, 192


def patterned(e: int, t: int, rng: np.random.Generator, shape: tuple[int, int] = (H, W)) -> np.ndarray:
    """Top quarter: a solid colour encoding (episode, step); the rest: noise that makes files big."""
    h, w = shape
    img = np.empty((h, w, 3), np.uint8)
    img[: h // 4] = (t % 256, (e * 37) % 256, 200)
    img[h // 4 :] = rng.integers(0, 256, (h - h // 4, w, 3), dtype=np.uint8)
    return img


def unit_schema(state_dim: int = 4, shape: tuple[int, int] = (H, W)) -> DatasetSchema:
    return DatasetSchema(
        fps=10,
        state_names=tuple(f"s{i}" for i in range(state_dim)),
        action_names=("a0", "a1"),
        cameras={"cam": CameraShape(*shape)},
        robot_type="unit",
    )


def episode_states(e: int, n: int, state_dim: int = 4) -> list[np.ndarray]:
    rng = np.random.default_rng([0, e])
    states = []
    for t in range(n):
        state = rng.standard_normal(state_dim).astype(np.float32)
        state[0] = t
        states.append(state)
    return states


def dataset_states(lengths: list[int], state_dim: int = 4) -> list[np.ndarray]:
    """Every frame's state of a dataset of episodes `lengths`, in frame order."""
    return [s for e, n in enumerate(lengths) for s in episode_states(e, n, state_dim)]


def write_episodes(
    bridge: DatasetBridge,
    lengths: list[int],
    *,
    first: int = 0,
    state_dim: int = 4,
    shape: tuple[int, int] = (H, W),
    tasks: list[str] | None = None,
    after_each: Callable[[int], None] | None = None,
) -> None:
    """Write episodes `first`, ..., `len(lengths) - 1` through `bridge`; `after_each(e)` once `end_episode`
    returned."""
    for e in range(first, len(lengths)):
        n = lengths[e]
        rng = np.random.default_rng([1, e])
        bridge.begin_episode(seed=100 + e, initial_state={"e": e})
        for t, state in enumerate(episode_states(e, n, state_dim)):
            task = tasks[e % len(tasks)] if tasks else "task"
            obs = Observation(images={"cam": patterned(e, t, rng, shape)}, state=state, task=task)
            bridge.add_step(obs, np.array([e, t], np.float32), reward=0.5, done=t == n - 1, success=t == n - 1)
        bridge.end_episode(success=e % 2 == 0)
        if after_each is not None:
            after_each(e)


def write_dataset(
    root: Path,
    lengths: list[int],
    *,
    state_dim: int = 4,
    tasks: list[str] | None = None,
    config: WriterConfig | None = None,
    check_after_each: bool = False,
    after_each: Callable[[int], None] | None = None,
    close: bool = True,
) -> tuple[LeRobotV3Writer, list[np.ndarray]]:
    """A fresh dataset at `root` (camera H x W); returns its writer and every frame's state. `after_each(e)`
    runs after episode e's commit; `close=False` leaves the writer open, as a process killed between two
    commits leaves its dataset."""
    schema = unit_schema(state_dim)
    writer = LeRobotV3Writer(root, schema, config)
    bridge = DatasetBridge(schema, [writer])
    states = dataset_states(lengths, state_dim)

    def each(e: int) -> None:
        if check_after_each:
            check_loads(root, lengths[: e + 1], states[: sum(lengths[: e + 1])], tasks)
        if after_each is not None:
            after_each(e)

    write_episodes(bridge, lengths, state_dim=state_dim, tasks=tasks, after_each=each)
    if close:
        bridge.close()
    return writer, states


def check_loads(
    root: Path,
    lengths: list[int],
    states: list[np.ndarray],
    tasks: list[str] | None = None,
    shape: tuple[int, int] = (H, W),
) -> None:
    """lerobot's loader, on the dataset as it is (no recovery), sees exactly the episodes `lengths`, each frame
    in its place: indices, state, action, task and the camera's top-stripe colour."""
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    ds = LeRobotDataset("local/unit", root=root, video_backend="pyav")
    assert len(ds) == sum(lengths) and ds.num_episodes == len(lengths), (len(ds), ds.num_episodes, lengths)
    h = shape[0]
    i = 0
    for e, n in enumerate(lengths):
        for t in range(n):
            item = ds[i]
            assert (int(item["episode_index"]), int(item["frame_index"]), int(item["index"])) == (e, t, i)
            np.testing.assert_array_equal(item["observation.state"].numpy(), states[i])
            np.testing.assert_array_equal(item["action"].numpy(), [e, t])
            top = item["observation.images.cam"].numpy()[:, 4 : h // 4 - 4].mean(axis=(1, 2)) * 255
            assert np.abs(top - [t % 256, (e * 37) % 256, 200]).max() < 6, (e, t, top)
            if tasks:
                assert item["task"] == tasks[e % len(tasks)]
            i += 1
