"""Decode one episode's camera frames and encode them again, for `edit.videos`.

Frames come from the episode's mp4 clip (`clip_frames`, optionally resized) or from a `dtype: image` column
(`image_frames`), one at a time; `CameraEncoders` feeds them to the writer's own encoder threads
(`video.EncoderWorker`, lerobot's encoder settings from `VideoSettings`), all cameras of an episode at once, and
returns each camera's complete mp4 with the statistics of the frames it encoded (what the writer keeps while
recording). Only one episode's frames are ever in flight.
"""

from __future__ import annotations

import contextlib
import io
import tempfile
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import av
import numpy as np
import numpy.typing as npt
import pyarrow as pa

from openral_data.errors import DatasetError
from openral_data.formats.lerobot_v3.encoder import VideoSettings, encoder_threads
from openral_data.formats.lerobot_v3.images import decode_image
from openral_data.formats.lerobot_v3.stats import ImageStatsAccumulator
from openral_data.formats.lerobot_v3.video import EncoderWorker
from openral_data.types import CameraShape

Pixels = npt.NDArray[np.uint8]


def clip_frames(data: bytes, source: str, size: CameraShape | None = None) -> Iterator[Pixels]:
    """The RGB frames of an mp4 held in memory, in order; resized (bilinear) to `size` when given."""
    try:
        with av.open(io.BytesIO(data), mode="r") as container:
            for decoded in container.decode(video=0):
                frame = decoded
                if size is not None and (frame.height, frame.width) != (size.height, size.width):
                    frame = frame.reformat(width=size.width, height=size.height, interpolation="BILINEAR")
                yield np.asarray(frame.to_ndarray(format="rgb24"), dtype=np.uint8)
    except av.error.FFmpegError as exc:
        raise DatasetError(f"{source}: cannot decode video: {exc}", code="dataset.invalid") from None


def image_frames(column: pa.Array, source: str) -> Iterator[Pixels]:
    """The frames of a `dtype: image` column (one encoded picture per row), decoded to RGB, in order."""
    for t, cell in enumerate(column.to_pylist()):
        yield decode_image(cell, f"{source}: frame {t}")


@dataclass(frozen=True)
class Encoded:
    data: bytes  # a complete mp4 of the episode, frame k at k / fps
    stats: ImageStatsAccumulator  # of the frames handed to the encoder


class CameraEncoders:
    """One encoder thread per camera, kept for a whole operation; `encode` does one episode of every camera."""

    def __init__(self, shapes: dict[str, CameraShape], settings: VideoSettings, fps: int) -> None:
        self.shapes = shapes
        self._tmp = tempfile.TemporaryDirectory(prefix="openral-videos-")
        budget = encoder_threads(settings, len(shapes))  # the cameras' encoders share the cores
        self._workers = {name: EncoderWorker(name, settings, fps, threads=budget) for name in shapes}

    def encode(self, frames: dict[str, Iterator[Pixels]], n: int, source: str) -> dict[str, Encoded]:
        """Encode exactly `n` frames of each camera (interleaved: the cameras' encoders run side by side)."""
        for name, worker in self._workers.items():
            shape = self.shapes[name]
            worker.begin(Path(self._tmp.name) / f"{name}.mp4", shape.height, shape.width)
        try:
            for t in range(n):
                for name, it in frames.items():
                    self._workers[name].put(self._checked(next(it, None), name, t, n, source))
            for name, it in frames.items():
                if next(it, None) is not None:
                    raise DatasetError(
                        f"{source}: camera {name}: more than the episode's {n} frames", code="dataset.invalid"
                    )
            out: dict[str, Encoded] = {}
            for name, worker in self._workers.items():
                enc = worker.finish()
                assert isinstance(enc.stats, ImageStatsAccumulator)  # colour workers (editing refuses depth)
                out[name] = Encoded(enc.path.read_bytes(), enc.stats)
                enc.path.unlink()
            return out
        except BaseException:
            for worker in self._workers.values():
                worker.abort()
            raise

    def _checked(self, frame: Pixels | None, name: str, t: int, n: int, source: str) -> Pixels:
        if frame is None:
            raise DatasetError(f"{source}: camera {name}: {t} frames, the episode has {n}", code="dataset.invalid")
        shape = self.shapes[name]
        if frame.shape != (shape.height, shape.width, 3):
            raise DatasetError(
                f"{source}: camera {name}: frame {t} is {frame.shape[1]}x{frame.shape[0]}, "
                f"the feature says {shape.width}x{shape.height}",
                code="dataset.invalid",
            )
        return frame

    def close(self) -> None:
        try:
            for worker in self._workers.values():
                with contextlib.suppress(Exception):
                    worker.close()
        finally:
            self._tmp.cleanup()
