"""The debug video observer on its own: layout (common height, even size), one file per committed episode,
nothing for a discarded one, no frame dropped behind a tiny queue, and never a file replaced."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import numpy.typing as npt
import pytest

from openral_data.errors import EncoderError, OutputExists
from openral_data.types import CameraShape, DatasetSchema, EpisodeRecord, EpisodeStart, Frame
from openral_data.viz.debug_video import DebugVideo, existing_videos
from tests.support.debug_video import decode, leftovers
from tests.support.lerobot import COLOUR_TOL

START = EpisodeStart(seed=0, initial_state={})
# odd sizes and different heights: `tall` sets the common height (60), `small` (17x30) is shown at 34x60
SCHEMA = DatasetSchema(
    fps=10,
    state_names=("s0",),
    action_names=tuple(f"a{i}" for i in range(14)),
    cameras={"small": CameraShape(height=30, width=17), "tall": CameraShape(height=60, width=41)},
    robot_type="test",
)


def _frame(t: int, episode: int) -> Frame:
    images: dict[str, npt.NDArray[np.uint8]] = {
        "small": np.full((30, 17, 3), (t, episode, 200), dtype=np.uint8),
        "tall": np.full((60, 41, 3), (t, episode, 60), dtype=np.uint8),
    }
    action = np.linspace(-1, 1, 14, dtype=np.float32) * (t + 1)
    return Frame(np.zeros(1, np.float32), action, images, "task", reward=float(t), done=False, success=t > 2)


def _episode(video: DebugVideo, index: int, length: int, keep: bool = True) -> None:
    video.begin_episode(index, START)
    for t in range(length):
        video.add_frame(_frame(t, index))
    video.end_episode(EpisodeRecord(index, length, True, 0) if keep else None)


def test_layout_frames_and_discard(tmp_path: Path) -> None:
    folder = tmp_path / "videos"
    video = DebugVideo(folder, SCHEMA, queue_size=1)  # a one-frame queue: the recording waits, nothing is dropped
    _episode(video, 0, 12)
    _episode(video, 1, 7, keep=False)
    _episode(video, 2, 4)
    video.close()
    assert existing_videos(folder) == [0, 2] and leftovers(folder) == []
    for index, length in ((0, 12), (2, 4)):
        frames = decode(folder / f"episode_{index:06d}.mp4")
        assert len(frames) == length
        height, width, _ = frames[0].shape
        assert height % 2 == 0 and width % 2 == 0 and width >= 34 + 41 and height > 60
        for t, img in enumerate(frames):
            small = img[20:40, 10:24].reshape(-1, 3).mean(axis=0)  # `small` scaled to x 0..34, rows 0..60
            tall = img[20:40, 50:66].reshape(-1, 3).mean(axis=0)  # `tall` at x 34..75
            assert np.abs(small - (t, index, 200)).max() <= COLOUR_TOL, (index, t, small)
            assert np.abs(tall - (t, index, 60)).max() <= COLOUR_TOL, (index, t, tall)
            assert img[62:].std() > 20  # the strip's text
        # the strip changes with the step's numbers
        assert not np.array_equal(frames[0][62:], frames[1][62:])


def test_close_with_an_episode_open_leaves_nothing(tmp_path: Path) -> None:
    video = DebugVideo(tmp_path, SCHEMA)
    video.begin_episode(3, START)
    for t in range(5):
        video.add_frame(_frame(t, 3))
    video.close()  # the bridge discards first; closing without that leaves nothing either
    assert list(tmp_path.iterdir()) == []


def test_an_existing_video_is_never_replaced(tmp_path: Path) -> None:
    canary = tmp_path / "episode_000001.mp4"
    canary.write_bytes(b"not ours")
    video = DebugVideo(tmp_path, SCHEMA)
    with pytest.raises(OutputExists, match=r"episode_000001\.mp4"):
        video.begin_episode(1, START)
    # one that appears while the episode is being encoded: the encoder thread refuses to replace it
    video.begin_episode(2, START)
    video.add_frame(_frame(0, 2))
    (tmp_path / "episode_000002.mp4").write_bytes(b"appeared meanwhile")
    video.end_episode(EpisodeRecord(2, 1, True, 0))
    with pytest.raises(EncoderError, match="debug video"):
        video.close()
    assert canary.read_bytes() == b"not ours"
    assert (tmp_path / "episode_000002.mp4").read_bytes() == b"appeared meanwhile"
    assert leftovers(tmp_path) == []


def test_a_depth_camera_is_drawn_grey_near_bright_and_no_return_black() -> None:
    from openral_data.viz.debug_video import Compositor

    schema = DatasetSchema(
        fps=10,
        state_names=("s0",),
        action_names=("a0",),
        cameras={"front_depth": CameraShape(height=32, width=32, depth_unit="m")},
        robot_type="test",
    )
    depth = np.full((32, 32), 2.0, dtype=np.float32)
    depth[:8] = 0.5  # near: white
    depth[-8:] = np.inf  # nothing hit: black
    frame = Frame(
        state=np.zeros(1, dtype=np.float32),
        action=np.zeros(1, dtype=np.float32),
        images={"front_depth": depth},
        task="t",
        reward=0.0,
        done=False,
        success=False,
    )
    canvas = Compositor(schema).draw(0, 0, frame)
    assert (canvas[:8, :32] == 255).all() and (canvas[8:24, :32] == 32).all() and (canvas[24:32, :32] == 0).all()
