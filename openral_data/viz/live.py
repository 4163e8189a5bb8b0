"""`record --view`: the run in rerun while it records, with the entities and layout of `view` (viz/entities.py).

`LiveView` is a frame observer: the bridge hands it each frame after the sinks took it, and it only queues the
frame for a background thread that logs it. At most `max_pending` frames wait; a frame that arrives when that
many are waiting is dropped (counted, reported on stderr at the end) — a slow viewer never slows the recording,
and the dataset never misses a frame (the sinks had it first). Episode starts and ends are never dropped. The
cameras' pictures are shown at most `IMAGE_HZ` times a second of the episode (the state, action and outcome series
at every frame): the viewer's rate, not the recording's.

Each episode is a recording of its own (application `openral-data`, recording id `<run>-episode-<N>`), as
`view` shows one episode. Where the viewer is: `--view-address URL` connects to a running viewer or server;
else with a display (DISPLAY / WAYLAND_DISPLAY) a viewer is spawned on `--view-port`; else this process serves
the stream on `--view-port` (gRPC; `rerun --connect <address>` shows it) and rerun's own web viewer (bundled in
the rerun-sdk wheel: no download) on the next port, and prints the page to open in a browser on stderr.
"""

from __future__ import annotations

import queue
import socket
import sys
import threading
import uuid
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, TextIO
from urllib.parse import quote

import numpy as np
import numpy.typing as npt
import rerun as rr

from openral_data.errors import UsageError
from openral_data.types import DatasetSchema, EpisodeRecord, EpisodeStart, Frame
from openral_data.viz import DEFAULT_PORT
from openral_data.viz.entities import (
    APP_ID,
    FRAME,
    OUTCOMES,
    TASK,
    TIME,
    camera_entity,
    log_episode_end,
    log_outcome_style,
    log_series_styles,
    outcome_entity,
    series_entities,
)
from openral_data.viz.rerun_view import has_display

MAX_PENDING = 32  # frames waiting for the viewer thread before live frames are dropped
# the pictures shown at most this often (the series every frame): what a person watching needs, and a teleop
# session on 2 cores spends the rest on its control loop (benchmarks/README.md, teleop overruns)
IMAGE_HZ = 10.0


@dataclass(frozen=True)
class _Begin:
    index: int


@dataclass(frozen=True)
class _Preview:
    index: int
    images: dict[str, npt.NDArray[Any]]


@dataclass(frozen=True)
class _End:
    success: bool | None
    discarded: bool


_STOP = object()


@dataclass
class LiveStats:
    shown: int = 0
    dropped: int = 0
    errors: list[str] = field(default_factory=list)


def check_port(port: int, option: str = "--view-port") -> None:
    """The port is free to serve on (else one line naming `option`, before anything is recorded)."""
    if not 0 < port < 65536:
        raise UsageError(f"{option}: {port}: not a TCP port (1..65535)")
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        try:
            s.bind(("0.0.0.0", port))
        except OSError as exc:
            raise UsageError(f"{option}: {port}: cannot serve there ({exc.strerror})") from exc


def check_address(address: str) -> None:
    if not address.startswith(("rerun://", "rerun+http://", "rerun+https://")) or not address.endswith("/proxy"):
        raise UsageError(f"--view-address: {address!r}: expected rerun+http://HOST:PORT/proxy")


def check_view_options(port: int, address: str | None) -> None:
    """`--view-address` is a proxy URL; a port to serve on is free (a viewer spawned on a busy port is the running
    viewer there, reused, so a display is not checked)."""
    if address is not None:
        check_address(address)
    elif not has_display():
        check_port(port)
        check_port(port + 1)  # rerun's web viewer, beside the stream


Connect = Callable[[rr.RecordingStream], None]


class LiveView:
    """A FrameObserver that shows the run in rerun from a background thread (see the module docstring)."""

    def __init__(
        self,
        schema: DatasetSchema,
        connect: Connect,
        *,
        max_pending: int = MAX_PENDING,
        run_id: str | None = None,
        hub: rr.RecordingStream | None = None,
        err: TextIO | None = None,
        image_hz: float = IMAGE_HZ,
    ) -> None:
        self.schema = schema
        self._image_period = 1.0 / image_hz
        self.stats = LiveStats()
        self._connect = connect  # gives an episode's recording stream its sink
        self._run = run_id or new_run_id()
        self._hub = hub  # a stream that serves the others (disconnecting it stops the server): closed last
        self._max_pending = max_pending
        self._pending = 0
        self._lock = threading.Lock()
        self._queue: queue.SimpleQueue[object] = queue.SimpleQueue()
        self._err = err
        self._closed = False
        self._thread = threading.Thread(target=self._run_loop, name="openral-live-view", daemon=True)
        self._thread.start()

    # -- the recording's side: never waits ---------------------------------------------------------------------
    def begin_episode(self, index: int, start: EpisodeStart) -> None:
        self._queue.put(_Begin(index))

    def preview(self, index: int, images: dict[str, npt.NDArray[Any]]) -> None:
        """Where episode `index` starts, shown before it records (a person waiting to press space sees the scene):
        its cameras at frame 0 of the episode's own recording, which its frames then continue."""
        self._queue.put(_Preview(index, images))

    def add_frame(self, frame: Frame) -> None:
        with self._lock:
            if self._pending >= self._max_pending or self.stats.errors:
                self.stats.dropped += 1
                return
            self._pending += 1
        self._queue.put(frame)

    def end_episode(self, record: EpisodeRecord | None) -> None:
        self._queue.put(_End(None if record is None else record.success, record is None))

    def close(self) -> None:
        if self._closed:
            return
        self._closed = True
        self._queue.put(_STOP)
        self._thread.join()
        if self._hub is not None:
            self._hub.flush()
            self._hub.disconnect()
        if self._err is not None:
            line = f"view: {self.stats.shown} frames shown, {self.stats.dropped} dropped (the viewer lagged)"
            if self.stats.errors:
                line += f"; stopped: {self.stats.errors[0]}"
            print(line, file=self._err, flush=True)

    # -- the viewer thread ---------------------------------------------------------------------------------------
    def _run_loop(self) -> None:
        rec: rr.RecordingStream | None = None
        episode, step, task, next_image = -1, 0, "", 0.0
        while True:
            item = self._queue.get()
            if item is _STOP:
                if rec is not None:  # the run stopped mid-episode without an end (it should not happen)
                    rec.disconnect()
                return
            if isinstance(item, Frame):
                with self._lock:
                    self._pending -= 1
            if self.stats.errors:
                continue
            try:
                if isinstance(item, _Preview | _Begin) and (rec is None or episode != item.index):
                    if rec is not None:  # (an episode without an end, a preview not followed by its episode)
                        rec.disconnect()
                    episode, step, task, next_image = item.index, 0, "", 0.0
                    rec = self._open_episode(item.index)
                if isinstance(item, _Preview) and rec is not None:
                    self._log_preview(rec, item.images)
                elif isinstance(item, Frame) and rec is not None:
                    if item.task != task:
                        task = item.task
                        rec.log(TASK, rr.TextDocument(task), static=True)
                    pictures = item.timestamp >= next_image - 1e-9  # (at most `image_hz`: the series every frame)
                    if pictures:
                        next_image = item.timestamp + self._image_period
                    self._log_frame(rec, step, item, pictures)
                    step += 1
                    self.stats.shown += 1
                elif isinstance(item, _End) and rec is not None:
                    if item.discarded:
                        rec.log("events", rr.TextLog(f"episode {episode} discarded", level="WARN"))
                    else:
                        log_episode_end(rec, episode, item.success)
                    rec.flush()
                    rec.disconnect()
                    rec, episode = None, -1
            except Exception as exc:  # noqa: BLE001 - the view stops; the recording goes on
                self.stats.errors.append(f"{type(exc).__name__}: {exc}")

    def _open_episode(self, index: int) -> rr.RecordingStream:
        rec = rr.RecordingStream(APP_ID, recording_id=f"{self._run}-episode-{index}")
        self._connect(rec)
        schema = self.schema
        log_series_styles(rec, series_entities("state", schema.state_names, schema.state_dim))
        log_series_styles(rec, series_entities("action", schema.action_names, schema.action_dim))
        for name in OUTCOMES:
            log_outcome_style(rec, name)
        return rec

    def _log_preview(self, rec: rr.RecordingStream, images: dict[str, npt.NDArray[Any]]) -> None:
        rec.set_time(FRAME, sequence=0)
        rec.set_time(TIME, duration=0.0)
        for cam, image in images.items():
            self._log_image(rec, cam, image)
        rec.log("events", rr.TextLog("waiting for the operator to start the episode"))

    def _log_image(self, rec: rr.RecordingStream, cam: str, image: npt.NDArray[Any]) -> None:
        unit = self.schema.cameras[cam].depth_unit
        shown = rr.Image(image) if unit is None else rr.DepthImage(image, meter=1.0 if unit == "m" else 1000.0)
        rec.log(camera_entity(cam), shown)

    def _log_frame(self, rec: rr.RecordingStream, step: int, frame: Frame, pictures: bool) -> None:
        rec.set_time(FRAME, sequence=step)
        rec.set_time(TIME, duration=frame.timestamp)
        for cam, image in frame.images.items() if pictures else ():
            self._log_image(rec, cam, image)
        schema = self.schema
        for base, values, names in (
            ("state", frame.state, schema.state_names),
            ("action", frame.action, schema.action_names),
        ):
            for (entity, _), value in zip(series_entities(base, names, len(values)), values, strict=True):
                rec.log(entity, rr.Scalars(float(value)))
        outcome = {"reward": frame.reward, "success": float(frame.success), "done": float(frame.done)}
        for name in OUTCOMES:
            rec.log(outcome_entity(name), rr.Scalars(np.float64(outcome[name])))


def open_live_view(
    schema: DatasetSchema, port: int = DEFAULT_PORT, address: str | None = None, err: TextIO | None = None
) -> LiveView:
    """Connect to `address`, else spawn a viewer (a display exists), else serve on `port`; say where on `err`."""
    out = err if err is not None else sys.stderr
    check_view_options(port, address)
    if address is not None:
        url = address
        print(f"view: sending to {url}", file=out, flush=True)
        return LiveView(schema, lambda rec: rec.connect_grpc(url), err=out)
    url = f"rerun+http://127.0.0.1:{port}/proxy"
    if has_display():
        rr.spawn(port=port, connect=False)
        print(f"view: opened a rerun viewer ({url})", file=out, flush=True)
        return LiveView(schema, lambda rec: rec.connect_grpc(url), err=out)
    run = new_run_id()
    hub = rr.RecordingStream(APP_ID, recording_id=run)  # owns the server for the whole run; the episodes send to it
    url = hub.serve_grpc(grpc_port=port)
    rr.serve_web_viewer(web_port=port + 1, open_browser=False)
    print(f"view: open {page_url(port + 1, url)} (or: rerun --connect {url})", file=out, flush=True)
    return LiveView(schema, lambda rec: rec.connect_grpc(url), run_id=run, hub=hub, err=out)


def page_url(web_port: int, stream: str) -> str:
    """The web viewer's page showing `stream` (rerun's `?url=` parameter)."""
    return f"http://127.0.0.1:{web_port}/?url={quote(stream, safe='')}"


def new_run_id() -> str:
    return uuid.uuid4().hex[:12]
