"""Reading `record --save-video` mp4s back with PyAV and checking them against what the mock scene drew."""

from __future__ import annotations

from pathlib import Path

import av
import numpy as np
import numpy.typing as npt

from tests.support.lerobot import COLOUR_TOL

# the mock scene's default cameras (tests/support/scenes.py): front 64x48 and wrist 32x32, shown at the common
# height 48 -> front at x 0..64, wrist scaled to 48x48 at x 64..112; the strip starts at row 48
CAMERA_HEIGHT = 48
CAMERA_CENTRES = {"front": (24, 32), "wrist": (24, 88)}


def decode(path: Path) -> list[npt.NDArray[np.uint8]]:
    """Every frame of `path` as RGB (what any PyAV user gets)."""
    with av.open(str(path)) as container:
        stream = container.streams.video[0]
        assert stream.codec_context.name == "h264" and stream.codec_context.pix_fmt == "yuv420p"
        frames: list[npt.NDArray[np.uint8]] = [f.to_ndarray(format="rgb24") for f in container.decode(stream)]  # type: ignore[misc]
    return frames


def check_mock_video(path: Path, episode: int, length: int) -> None:
    """`length` frames; frame t shows the mock's colour (t, episode, 128) in each camera's region, black beside
    the cameras, and a strip of text (many distinct pixel values) under them."""
    frames = decode(path)
    assert len(frames) == length, (path, len(frames), length)
    for t, img in enumerate(frames):
        want = np.array([t % 256, episode % 256, 128])
        for name, (y, x) in CAMERA_CENTRES.items():
            patch = img[y - 6 : y + 6, x - 6 : x + 6].reshape(-1, 3).mean(axis=0)
            assert np.abs(patch - want).max() <= COLOUR_TOL, (path, t, name, patch)
        assert img[4:40, 150:300].max() <= 2 * COLOUR_TOL, (path, t)  # right of the cameras: black
        strip = img[CAMERA_HEIGHT + 2 :]
        assert len(np.unique(strip.reshape(-1, 3), axis=0)) > 8 and strip.std() > 20, (path, t)


def leftovers(folder: Path) -> list[str]:
    """Files in `folder` that are not finished debug videos (hidden partial files of a discarded episode)."""
    return sorted(p.name for p in folder.iterdir() if not (p.name.startswith("episode_") and p.suffix == ".mp4"))
