"""`frame_drop`'s picture witness (`cuts.picture_drops`) measures each camera's change only at the frames its
candidate steps' jumps read (`cuts.reach`, `edges.Full.change_at`), decoding those frames alone from the mp4
(`frames.decode_episode_frames`): the change there is the whole decode's, and so are the findings."""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from fractions import Fraction
from pathlib import Path
from typing import Any

import av
import numpy as np
import numpy.typing as npt
import pytest

from openral_data.formats.lerobot_v3 import layout
from openral_data.formats.lerobot_v3.frames import decode_episode_frames, decode_episode_video
from openral_data.formats.lerobot_v3.sparse import sparse_frames
from openral_data.metrics.quality import cuts
from openral_data.metrics.quality.camera import luma
from openral_data.metrics.quality.edges import Full

FPS, SIDE, KEY, LENGTH, CUT = 10, 32, "observation.images.cam", 60, 30  # frames CUT-1..CUT-4 lost (a drop)
HELD = 12  # frame HELD holds frame HELD-1's picture, then the texture slides on


def _write(root: Path, codec: str, options: dict[str, str], b_frames: int) -> None:
    """One episode of a texture sliding 1 px a frame, 5 px onto frame CUT (the frames lost), held once at HELD."""
    wave = 128 + 100 * np.sin(np.arange(4 * SIDE) * 2 * np.pi / 40)  # smooth: a shift's change grows with it
    texture = np.repeat(np.broadcast_to(wave, (SIDE, 4 * SIDE))[..., None], 3, axis=2).astype(np.uint8)
    path = layout.video_path(root, KEY, layout.FilePos(0, 0))
    path.parent.mkdir(parents=True)
    with av.open(str(path), "w") as out:
        stream: av.VideoStream = out.add_stream(codec, rate=FPS, options=options)  # type: ignore[assignment]
        stream.width = stream.height = SIDE
        stream.pix_fmt = "yuv420p"
        stream.codec_context.max_b_frames = b_frames  # type: ignore[attr-defined]
        for t in range(LENGTH):
            x = t - (t >= HELD) + 4 * (t >= CUT)
            frame = av.VideoFrame.from_ndarray(np.ascontiguousarray(texture[:, x : x + SIDE]), format="rgb24")
            frame.pts, frame.time_base = t, Fraction(1, FPS)
            out.mux(stream.encode(frame))
        out.mux(stream.encode(None))


def _counted(source: Iterator[npt.NDArray[np.uint8]], seen: list[int]) -> Iterator[npt.NDArray[np.uint8]]:
    for rgb in source:
        seen.append(1)
        yield rgb


@pytest.mark.parametrize(
    ("codec", "options", "b_frames"),
    [("libx264", {"g": "2", "crf": "18"}, 0), ("mpeg4", {"g": "12", "qmax": "3"}, 2)],  # lerobot's GOP; B-frames
)
def test_the_drop_is_found_from_the_frames_around_the_candidates_alone(
    tmp_path: Path, codec: str, options: dict[str, str], b_frames: int
) -> None:
    _write(tmp_path, codec, options, b_frames)
    info = {"fps": FPS, "features": {KEY: {"dtype": "video", "shape": [SIDE, SIDE, 3]}}}
    row: dict[str, Any] = {
        "episode_index": 0, "length": LENGTH, f"videos/{KEY}/chunk_index": 0, f"videos/{KEY}/file_index": 0,
        f"videos/{KEY}/from_timestamp": 0.0, f"videos/{KEY}/to_timestamp": LENGTH / FPS,
    }  # fmt: skip
    whole: list[int] = []  # frames the decoder handed out: every frame
    picked: list[int] = []  # ... the frames asked for

    def every() -> Iterator[npt.NDArray[np.uint8]]:
        return _counted(decode_episode_video(tmp_path, info, row, KEY), whole)

    def some(wanted: Sequence[int]) -> Iterator[npt.NDArray[np.uint8]]:
        return _counted(decode_episode_frames(tmp_path, info, row, KEY, wanted), picked)

    reference = Full(every, luma).change()  # every frame decoded
    assert len(whole) == LENGTH and reference[CUT] > 3 * np.nanmax(reference[CUT - 3 : CUT])
    assert reference[HELD] < 0.5 * reference[HELD + 1]  # a held picture (a copy for mpeg4: no neighbour)
    steps = np.ones(LENGTH)
    steps[[CUT, HELD + 1, 50]] = 3.0  # the state steps far at the drop, past the copy, and on a plain frame
    need = cuts.reach(np.flatnonzero(steps >= cuts.STEP), LENGTH)
    assert need == [*range(HELD + 1 - 3, HELD + 1 + 5), *range(CUT - 3, CUT + 5), *range(47, 55)]

    whole.clear()
    full = Full(every, luma, some)
    found = cuts.picture_drops({KEY: full.change_at}, steps)
    assert [(f.check, f.start_frame) for f in found] == [("frame_drop", CUT)]
    assert not whole and full.measured is None  # the episode was never decoded whole
    # the frames the change at `need` takes (each and the one before), 27 of 60, nothing past the last window
    lumas = sorted({t for f in need for t in (f - 1, f)})
    assert len(picked) == len(lumas) == 27
    with av.open(str(layout.video_path(tmp_path, KEY, layout.FilePos(0, 0)))) as container:
        stream = container.streams.video[0]
        sent = sparse_frames(container, stream, 0.0, LENGTH, FPS, lumas)  # their packets alone
        assert [round((f.pts or 0) * (stream.time_base or 0) * FPS) for f in sent] == lumas  # no SparseGap
    windowed = full.change_at(need)
    assert np.array_equal(windowed[need], reference[need])  # the whole decode's values, to the bit
    assert np.isnan(np.delete(windowed, need)).all() and len(windowed) == need[-1] + 1
    # the findings are the whole decode's, and no value outside `need` is read: garbage there changes nothing
    assert cuts.picture_drops({KEY: lambda _: reference}, steps) == found
    garbage = np.random.default_rng(1).uniform(0, 100, LENGTH).astype(np.float32)
    garbage[need] = reference[need]
    assert cuts.picture_drops({KEY: lambda _: garbage}, steps) == found
    # once another check measured every frame, that measure is reused: nothing decoded again
    picked.clear()
    measured = Full(every, luma, some)
    measured.change()
    assert cuts.picture_drops({KEY: measured.change_at}, steps) == found and not picked
