"""A debug mp4 per recorded episode (`record --save-video`): the cameras side by side, scaled to a common height,
over a strip that shows the episode, step, reward, success and action of each row.

`DebugVideo` is a `FrameObserver`: the bridge shows it every validated frame after the sinks took it. Drawing
and encoding run in one background thread fed through a bounded queue; when the thread falls behind, the
recording waits (a debug video is a file the user asked for: no frame of it is dropped). An episode is
encoded into a hidden `.episode_NNNNNN.mp4.partial` and renamed to `episode_NNNNNN.mp4` once the bridge
reports it committed; a discarded episode's partial file is deleted. h264 (libx264, else libopenh264),
yuv420p, even dimensions; text in Pillow's built-in bitmap font. A depth camera is drawn grey (near = bright),
scaled per frame between its nearest and farthest finite pixel; pixels without depth are black.
"""

from __future__ import annotations

import contextlib
import os
import queue
import re
import threading
from dataclasses import dataclass
from fractions import Fraction
from pathlib import Path

import av
import numpy as np
import numpy.typing as npt
from PIL import Image, ImageDraw, ImageFont

from openral_data.errors import EncoderError, OutputExists
from openral_data.types import DatasetSchema, EpisodeRecord, EpisodeStart, Frame

ENCODERS = ("libx264", "libopenh264")  # the first one the PyAV wheel carries
OPTIONS = {"libx264": {"preset": "veryfast", "crf": "23"}}  # speed over size: a debug file
MIN_WIDTH = 320  # the strip needs room for its text; narrower cameras are padded on the right
NAME = re.compile(r"episode_(\d{6})\.mp4")
QUEUE_SIZE = 64  # frames waiting for the encoder thread before the recording waits for it


def video_name(index: int) -> str:
    return f"episode_{index:06d}.mp4"


def partial_name(index: int) -> str:
    return f".{video_name(index)}.partial"


def encoder_name() -> str:
    """The h264 encoder this PyAV build has (libx264, else libopenh264)."""
    for name in ENCODERS:
        if name in av.codecs_available:
            return name
    raise EncoderError(f"no h264 encoder in this PyAV build (looked for {', '.join(ENCODERS)})")


def existing_videos(folder: Path) -> list[int]:
    """The episode numbers of the debug videos already in `folder`."""
    if not folder.is_dir():
        return []
    return sorted(int(m.group(1)) for p in folder.iterdir() if (m := NAME.fullmatch(p.name)))


@dataclass(frozen=True)
class FrameLayout:
    """Where each camera goes in a debug frame, and the strip of text under them."""

    cameras: tuple[tuple[str, int, int], ...]  # (name, x, scaled width), in schema order
    camera_height: int
    width: int
    height: int
    line_height: int
    chars_per_line: int
    action_lines: int

    @staticmethod
    def of(schema: DatasetSchema, font: ImageFont.ImageFont) -> FrameLayout:
        common = max((c.height for c in schema.cameras.values()), default=0)
        placed: list[tuple[str, int, int]] = []
        x = 0
        for name, shape in schema.cameras.items():
            scaled = max(1, round(shape.width * common / shape.height))
            placed.append((name, x, scaled))
            x += scaled
        width = _even(max(x, MIN_WIDTH))
        left, top, right, bottom = font.getbbox("0")
        char_w, line_h = int(right - left), int(bottom - top) + 2
        per_line = max(1, (width - 8) // char_w)
        values = len(_action_words(np.zeros(schema.action_dim, dtype=np.float32)))
        per_action_line = max(1, (per_line - len("action ")) // 8)
        action_lines = max(1, -(-values // per_action_line))
        strip = (1 + action_lines) * line_h + 6
        return FrameLayout(tuple(placed), common, width, _even(common + strip), line_h, per_line, action_lines)


FARTHEST_GREY = 32  # the farthest valid depth: darker than every other, brighter than "no depth"


def depth_grey(depth: npt.NDArray[np.generic]) -> npt.NDArray[np.uint8]:
    """An (H, W) depth map as an RGB picture: nearest white, farthest dark grey (32), invalid (non-finite, 0) black."""
    d = np.asarray(depth, dtype=np.float64)
    valid = np.isfinite(d) & (d > 0)
    grey = np.zeros(d.shape, dtype=np.uint8)
    if valid.any():
        lo, hi = float(d[valid].min()), float(d[valid].max())
        scale = (255.0 - FARTHEST_GREY) / (hi - lo) if hi > lo else 0.0
        grey[valid] = np.rint(255.0 - (d[valid] - lo) * scale).astype(np.uint8)
    return np.repeat(grey[:, :, None], 3, axis=2)


def _even(n: int) -> int:
    return n + (n % 2)


def _action_words(action: npt.NDArray[np.float32]) -> list[str]:
    return [f"{float(v):+.3f}" for v in action]


class Compositor:
    """Draws one debug frame (HWC uint8 RGB) from a recorded frame."""

    def __init__(self, schema: DatasetSchema) -> None:
        self.font = ImageFont.load_default_imagefont()
        self.layout = FrameLayout.of(schema, self.font)

    def lines(self, index: int, step: int, frame: Frame) -> list[str]:
        lay = self.layout
        head = f"ep {index}  step {step}  reward {frame.reward:.3f}  success {'yes' if frame.success else 'no'}"
        words = _action_words(frame.action)
        per = max(1, (lay.chars_per_line - len("action ")) // 8)
        rows = [words[i : i + per] for i in range(0, len(words), per)] or [[]]
        action = [("action " if k == 0 else "       ") + " ".join(r) for k, r in enumerate(rows)]
        return [head[: lay.chars_per_line], *action[: lay.action_lines]]

    def draw(self, index: int, step: int, frame: Frame) -> npt.NDArray[np.uint8]:
        lay = self.layout
        canvas = np.zeros((lay.height, lay.width, 3), dtype=np.uint8)
        for name, x, scaled in lay.cameras:
            img = frame.images[name]
            if img.ndim == 2:
                img = depth_grey(img)
            if img.shape[0] != lay.camera_height or img.shape[1] != scaled:
                resized = Image.fromarray(img).resize((scaled, lay.camera_height), Image.Resampling.NEAREST)
                img = np.asarray(resized)
            canvas[: lay.camera_height, x : x + scaled] = img
        strip = Image.new("L", (lay.width, lay.height - lay.camera_height), 24)
        pen = ImageDraw.Draw(strip)
        for k, line in enumerate(self.lines(index, step, frame)):
            pen.text((4, 3 + k * lay.line_height), line, fill=255, font=self.font)
        canvas[lay.camera_height :] = np.asarray(strip)[:, :, None]
        return canvas


_STOP = object()


@dataclass(frozen=True)
class _Begin:
    index: int


@dataclass(frozen=True)
class _End:
    committed: bool


class DebugVideo:
    """`FrameObserver` writing `folder/episode_NNNNNN.mp4` for every committed episode (see the module doc)."""

    def __init__(self, folder: Path, schema: DatasetSchema, queue_size: int = QUEUE_SIZE) -> None:
        self.folder = folder
        self.fps = schema.fps
        self.encoder = encoder_name()
        self.compositor = Compositor(schema)
        self._q: queue.Queue[object] = queue.Queue(maxsize=queue_size)
        self._thread: threading.Thread | None = None
        self._failed: BaseException | None = None
        self.written: list[Path] = []  # the finished videos, in order

    # -- the recording's side ------------------------------------------------------------------------
    def begin_episode(self, index: int, start: EpisodeStart) -> None:
        self._raise_if_failed()
        target = self.folder / video_name(index)
        if target.exists() or target.is_symlink():
            raise OutputExists(f"{target}: --save-video: a debug video of episode {index} is already there")
        if self._thread is None:
            self.folder.mkdir(parents=True, exist_ok=True)
            self._thread = threading.Thread(target=self._run, name="debug-video", daemon=True)
            self._thread.start()
        self._q.put(_Begin(index))

    def add_frame(self, frame: Frame) -> None:
        self._raise_if_failed()
        self._q.put(frame)  # blocks while the queue is full: the recording waits, nothing is dropped

    def end_episode(self, record: EpisodeRecord | None) -> None:
        if self._thread is not None:
            self._q.put(_End(record is not None))

    def close(self) -> None:
        """Finish the videos of committed episodes still in the queue, then stop the thread."""
        if self._thread is not None:
            self._q.put(_STOP)
            self._thread.join()
            self._thread = None
        self._raise_if_failed()

    def _raise_if_failed(self) -> None:
        failed = self._failed
        if failed is not None:
            raise EncoderError(f"{self.folder}: --save-video: writing a debug video failed: {failed}") from failed

    # -- the encoder thread --------------------------------------------------------------------------
    def _run(self) -> None:
        stopped = False
        while not stopped:
            item = self._q.get()
            if item is _STOP:
                return
            if isinstance(item, _Begin) and self._failed is None:
                try:
                    stopped = self._episode(item.index)
                except BaseException as exc:  # noqa: BLE001 - reported to the recording's thread
                    self._failed = exc
            # anything else (the rest of a failed episode's frames, or everything after a failure) is dropped,
            # so the recording is never blocked by a full queue

    def _episode(self, index: int) -> bool:
        """Encode one episode's frames until its end marker; keep the file only for a committed episode.
        Returns whether the marker was the stop marker (closed with the episode open)."""
        partial = self.folder / partial_name(index)
        lay = self.compositor.layout
        container = av.open(str(partial), mode="w", format="mp4")
        try:
            stream: av.VideoStream = container.add_stream(
                self.encoder, rate=self.fps, options=OPTIONS.get(self.encoder, {})
            )  # type: ignore[assignment]
            stream.width, stream.height, stream.pix_fmt = lay.width, lay.height, "yuv420p"
            stream.codec_context.time_base = Fraction(1, self.fps)
            step = 0
            while isinstance(item := self._q.get(), Frame):
                vf = av.VideoFrame.from_ndarray(self.compositor.draw(index, step, item), format="rgb24")
                vf.pts = step
                step += 1
                for packet in stream.encode(vf):
                    container.mux(packet)
            for packet in stream.encode(None):
                container.mux(packet)
            container.close()
            if isinstance(item, _End) and item.committed and step:
                target = self.folder / video_name(index)
                _place(partial, target)
                self.written.append(target)
            return item is _STOP
        finally:
            with contextlib.suppress(Exception):
                container.close()
            with contextlib.suppress(OSError):
                partial.unlink()


def _place(partial: Path, target: Path) -> None:
    """Give the finished file its name without ever replacing a file that appeared there meanwhile."""
    try:
        os.link(partial, target)
    except FileExistsError:
        raise
    except OSError:  # a file system without hard links: check, then rename
        if target.exists() or target.is_symlink():
            raise FileExistsError(target) from None
        os.replace(partial, target)
