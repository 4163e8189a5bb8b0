"""`decode_episode_video` with a stride decodes only the packets its frames need (formats/lerobot_v3/sparse.py) and
gives the same pictures as decoding the episode whole: frame k*stride of the episode is the picture filmed at
step k*stride, for the layouts an mp4 of a LeRobot dataset takes (lerobot's GOP of 2, long GOPs with B-frames
that reorder, AV1), an episode in the middle of a file, and time stamps off the frame grid (then the whole span
is decoded and frames are counted, as without a stride)."""

from __future__ import annotations

from collections.abc import Iterator
from fractions import Fraction
from pathlib import Path
from typing import Any

import av
import numpy as np
import pytest

from openral_data.errors import DatasetError, SparseGap
from openral_data.formats.lerobot_v3 import frames, layout, sparse
from openral_data.formats.lerobot_v3.frames import decode_episode_video

FPS, SIDE, KEY = 10, 32, "observation.images.cam"
EPISODES = (23, 31, 17)  # frames of the three episodes the file holds, in order


def _level(step: int) -> int:
    """The grey of the picture filmed at `step` of its episode (its identity once decoded)."""
    return 24 + 6 * step


def _write(root: Path, codec: str, options: dict[str, str], b_frames: int, off_grid: int | None = None) -> Path:
    """One mp4 with the EPISODES back to back; with `off_grid`, that frame of the file is stamped 0.4 frame late."""
    path = layout.video_path(root, KEY, layout.FilePos(0, 0))
    path.parent.mkdir(parents=True)
    with av.open(str(path), "w") as out:
        stream: av.VideoStream = out.add_stream(codec, rate=10 * FPS, options=options)  # type: ignore[assignment]
        stream.width = stream.height = SIDE
        stream.pix_fmt = "yuv420p"
        stream.codec_context.max_b_frames = b_frames  # type: ignore[attr-defined]
        k = 0
        for length in EPISODES:
            for step in range(length):
                picture = np.full((SIDE, SIDE, 3), _level(step), dtype=np.uint8)
                picture[: SIDE // 4, : SIDE // 4] = 255 - _level(step)  # a corner, so the picture has an edge
                frame = av.VideoFrame.from_ndarray(picture, format="rgb24")
                frame.pts = 10 * k + (4 if k == off_grid else 0)
                frame.time_base = Fraction(1, 10 * FPS)
                out.mux(stream.encode(frame))
                k += 1
        out.mux(stream.encode(None))
    return path


def _episode(e: int) -> tuple[dict[str, Any], dict[str, Any]]:
    start = sum(EPISODES[:e]) / FPS
    info = {"fps": FPS, "features": {KEY: {"dtype": "video", "shape": [SIDE, SIDE, 3]}}}
    row = {
        "episode_index": e, "length": EPISODES[e], f"videos/{KEY}/chunk_index": 0, f"videos/{KEY}/file_index": 0,
        f"videos/{KEY}/from_timestamp": start, f"videos/{KEY}/to_timestamp": start + EPISODES[e] / FPS,
    }  # fmt: skip
    return info, row


def _steps(root: Path, e: int, stride: int, videos: frames.OpenVideos | None = None) -> list[int]:
    """The step each decoded picture of episode `e` was filmed at, read back from its grey."""
    info, row = _episode(e)
    return [
        round((float(p[SIDE // 2 :, SIDE // 2 :].mean()) - 24) / 6)
        for p in decode_episode_video(root, info, row, KEY, stride, videos)
    ]


LAYOUTS = {
    "h264-gop2": ("libx264", {"g": "2", "crf": "18"}, 0),  # lerobot's default GOP
    "mpeg4-bframes": ("mpeg4", {"g": "12", "qmax": "3"}, 2),  # decoded out of display order
    "av1-gop2": ("libsvtav1", {"g": "2", "crf": "30", "preset": "12"}, 0),
}


@pytest.fixture
def gaps(monkeypatch: pytest.MonkeyPatch) -> list[str]:
    """Why each sparse decode gave up (and the span was decoded whole): sparse_frames watched, not replaced."""
    seen: list[str] = []

    def watched(*args: Any) -> Iterator[Any]:
        try:
            yield from sparse.sparse_frames(*args)
        except SparseGap as gap:
            seen.append(str(gap))
            raise

    monkeypatch.setattr(frames, "sparse_frames", watched)
    return seen


@pytest.mark.parametrize("layout_name", sorted(LAYOUTS))
def test_every_strided_frame_is_the_one_filmed_at_that_step(tmp_path: Path, layout_name: str, gaps: list[str]) -> None:
    codec, options, b_frames = LAYOUTS[layout_name]
    _write(tmp_path, codec, options, b_frames)
    for e, length in enumerate(EPISODES):
        whole = _steps(tmp_path, e, 1)
        assert whole == list(range(length)), (e, whole)
        for stride in (2, 5, 7):
            assert _steps(tmp_path, e, stride) == list(range(0, length, stride)), (e, stride)
    # every strided span was decoded sparsely; an open GOP's leading frames at a span's start are found by seeking
    # further back (mpeg4's B-frames shown before the keyframe found), never by decoding the span whole
    assert set(gaps) <= ({"frame 0 never decoded"} if b_frames else set()), gaps


def test_a_kept_open_video_gives_each_episode_its_own_frames(
    tmp_path: Path, gaps: list[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    """`OpenVideos`: the episodes of one mp4 decoded through one kept-open container, in any order, a decode
    abandoned half way between, give the frames a fresh open gives; the file is opened again only for a span
    from its start (nothing to seek) — here twice, not once per decode."""
    _write(tmp_path, "libx264", {"g": "2", "crf": "18"}, 0)
    opened: list[str] = []
    real_open = av.open

    def counted(*args: Any, **kwargs: Any) -> Any:
        opened.append(str(args[0]))
        return real_open(*args, **kwargs)

    monkeypatch.setattr(av, "open", counted)
    with frames.OpenVideos() as videos:
        for e, stride in ((2, 5), (1, 1), (2, 1), (1, 7), (0, 5), (2, 2), (1, 5)):
            assert _steps(tmp_path, e, stride, videos) == list(range(0, EPISODES[e], stride)), (e, stride)
            info, row = _episode(1)
            next(decode_episode_video(tmp_path, info, row, KEY, 1, videos))  # left half way
        assert len(videos.held) == 1
    assert len(opened) == 2 and not gaps  # the first decode and episode 0's span
    assert not videos.held  # closed on leaving


def test_stamps_off_the_grid_are_counted_as_without_a_stride(tmp_path: Path, gaps: list[str]) -> None:
    _write(tmp_path, "libx264", {"g": "2", "crf": "18"}, 0, off_grid=EPISODES[0] + 7)  # episode 1, frame 7
    assert _steps(tmp_path, 1, 5) == list(range(0, EPISODES[1], 5))
    assert len(gaps) == 1 and "off the 10 fps grid" in gaps[0]
    assert _steps(tmp_path, 1, 1) == list(range(EPISODES[1]))


def test_a_video_shorter_than_its_episode_is_refused_in_one_line(tmp_path: Path) -> None:
    _write(tmp_path, "libx264", {"g": "2", "crf": "18"}, 0)
    info, row = _episode(2)
    row["length"] = EPISODES[2] + 6  # meta/episodes claims frames the file does not hold
    row[f"videos/{KEY}/to_timestamp"] = row[f"videos/{KEY}/from_timestamp"] + row["length"] / FPS
    for stride in (1, 5):
        with pytest.raises(
            DatasetError, match=f"video ends after {EPISODES[2]} of the episode's {row['length']} frames"
        ):
            list(decode_episode_video(tmp_path, info, row, KEY, stride))
