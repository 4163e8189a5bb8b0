"""Frames in, encoders out (`edit.recode`): a round trip through the writer's encoder, resizing, and the episode's
frame count and size enforced in one line; the encoders stay usable after a refused episode."""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np
import pyarrow as pa
import pytest

from openral_data.edit.recode import CameraEncoders, clip_frames, image_frames
from openral_data.errors import DatasetError
from openral_data.formats.lerobot_v3.encoder import VideoSettings
from openral_data.types import CameraShape

SHAPE = CameraShape(height=48, width=64)


def _frame(t: int, shape: CameraShape = SHAPE) -> np.ndarray:
    y, x = np.mgrid[0 : shape.height, 0 : shape.width]
    return np.stack([x * 3 + t * 5, y * 4, np.full_like(x, 100 + t)], axis=-1).astype(np.uint8)


@pytest.fixture
def encoders() -> Iterator[CameraEncoders]:
    enc = CameraEncoders({"cam": SHAPE}, VideoSettings(codec="h264"), fps=10)
    yield enc
    enc.close()


def test_round_trip_and_resize(encoders: CameraEncoders) -> None:
    out = encoders.encode({"cam": iter([_frame(t) for t in range(5)])}, 5, "src")["cam"]
    assert out.stats.frames == 5
    decoded = list(clip_frames(out.data, "src"))
    assert len(decoded) == 5
    for t, frame in enumerate(decoded):
        assert frame.shape == (48, 64, 3)
        assert np.abs(frame.astype(float) - _frame(t)).mean() < 3.0
    small = list(clip_frames(out.data, "src", CameraShape(height=24, width=32)))
    assert [f.shape for f in small] == [(24, 32, 3)] * 5


def test_wrong_frame_count_or_size_is_one_line_and_the_encoders_go_on(encoders: CameraEncoders) -> None:
    with pytest.raises(DatasetError) as err:
        encoders.encode({"cam": iter([_frame(t) for t in range(4)])}, 5, "src: episode 2")
    assert err.value.code == "dataset.invalid"
    assert str(err.value) == "src: episode 2: camera cam: 4 frames, the episode has 5"
    with pytest.raises(DatasetError, match="more than the episode's 3 frames"):
        encoders.encode({"cam": iter([_frame(t) for t in range(4)])}, 3, "src")
    with pytest.raises(DatasetError, match="frame 0 is 32x24, the feature says 64x48"):
        encoders.encode({"cam": iter([_frame(0, CameraShape(24, 32))])}, 1, "src")
    assert encoders.encode({"cam": iter([_frame(0)])}, 1, "src")["cam"].stats.frames == 1


def test_undecodable_input_is_one_line() -> None:
    with pytest.raises(DatasetError, match=r"^src: cannot decode video"):
        list(clip_frames(b"\x00\x00\x00\x18ftypgarbage" * 20, "src"))
    cells = pa.array([{"bytes": b"not a png", "path": None}])
    with pytest.raises(DatasetError, match=r"^src: frame 0: cannot decode image"):
        list(image_frames(cells, "src"))
