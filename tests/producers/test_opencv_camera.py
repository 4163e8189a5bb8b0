"""Cameras on the robot: lerobot's `OpenCVCamera` (real OpenCV, opencv-python-headless) behind the HAL.

Sources made here: a lossless video file written by PyAV, and the same stream served over HTTP by a server
in this process that sends it at a set frame rate and can stall. The camera is named in the robot manifest's
`hardware.cameras` (a lerobot camera config), read on its own capture thread with its own stamps, and recorded
through the fixed-rate loop with the SO-101 follower on a SIMULATED Feetech bus.
"""

from __future__ import annotations

import contextlib
import http.server
import itertools
import os
import socketserver
import threading
import time
from pathlib import Path
from typing import Any

import av
import numpy as np
import numpy.typing as npt
import pytest
import yaml

from openral_data.errors import HalError
from openral_data.producers.hal.cameras.sensors import CameraSample
from openral_data.producers.hal.robots.lerobot_hw import make_cameras
from openral_data.record.hal import HalRecordOptions, record_hal
from openral_data.schemas.hal import HardwareConfig
from tests.support.feetech_bus import SimulatedFeetechBus
from tests.support.hal import episode_infos, frames_table
from tests.support.inproc import run_inproc

W, H, N, RATE = 64, 48, 120, 20
Image = npt.NDArray[np.uint8]


def source_frame(k: int) -> Image:
    """Frame k: four flat quadrants whose levels say k (coarse enough for a lossy codec), RGB."""
    img = np.zeros((H, W, 3), np.uint8)
    img[: H // 2, : W // 2] = (k * 7) % 256
    img[: H // 2, W // 2 :] = (k * 13 + 60) % 256
    img[H // 2 :, : W // 2] = (k * 29 + 120) % 256
    img[H // 2 :, W // 2 :, 0] = np.arange(W // 2, dtype=np.uint8)[None, :] * 4
    return img


def write_video(path: Path, n: int = N) -> bytes:
    """A lossless NUT file (rawvideo bgr24: OpenCV's own pixel order) of frames 0..n-1; its bytes."""
    with av.open(str(path), "w") as c:
        s = c.add_stream("rawvideo", rate=RATE)
        assert isinstance(s, av.VideoStream)
        s.width, s.height, s.pix_fmt = W, H, "bgr24"
        for k in range(n):
            c.mux(s.encode(av.VideoFrame.from_ndarray(source_frame(k), format="rgb24")))
        c.mux(s.encode())
    return path.read_bytes()


class StreamServer:
    """Serves `data` at `/stream.nut` over HTTP in `N` slices, one per 1/RATE s (a live camera's pace); after
    slice `stall_at` it sends nothing for `stall_s` seconds."""

    def __init__(self, data: bytes, stall_at: int | None = None, stall_s: float = 0.0) -> None:
        outer = self

        class Handler(http.server.BaseHTTPRequestHandler):
            def do_GET(self) -> None:
                self.send_response(200)
                self.send_header("Content-Type", "video/x-nut")
                self.end_headers()
                step = -(-len(data) // N)
                for k, i in enumerate(range(0, len(data), step)):
                    if outer.stop.is_set():
                        return
                    self.wfile.write(data[i : i + step])
                    self.wfile.flush()
                    time.sleep(1 / RATE + (stall_s if k == stall_at else 0.0))

            def log_message(self, *args: Any) -> None:
                pass

        self.stop = threading.Event()
        self.server = socketserver.ThreadingTCPServer(("127.0.0.1", 0), Handler)
        self.server.daemon_threads = True
        self.url = f"http://127.0.0.1:{self.server.server_address[1]}/stream.nut"
        threading.Thread(target=self.server.serve_forever, daemon=True).start()

    def close(self) -> None:
        self.stop.set()
        self.server.shutdown()
        self.server.server_close()


def nearest(img: Image) -> tuple[int, float]:
    """The source frame an image is (index, mean absolute difference)."""
    errs = [float(np.abs(img.astype(np.int16) - source_frame(k)).mean()) for k in range(N)]
    k = int(np.argmin(errs))
    return k, errs[k]


def feed(path: Path, data: bytes) -> threading.Thread:
    """Write `data` into the named pipe `path` in `N` slices at RATE per second (opening blocks until read)."""

    def run() -> None:
        step = -(-len(data) // N)
        with contextlib.suppress(BrokenPipeError), path.open("wb") as pipe:
            for i in range(0, len(data), step):
                pipe.write(data[i : i + step])
                pipe.flush()
                time.sleep(1 / RATE)

    thread = threading.Thread(target=run, daemon=True)
    thread.start()
    return thread


@pytest.mark.slow
def test_a_video_file_through_lerobots_opencv_camera(tmp_path: Path) -> None:
    """The file written by PyAV, fed at its frame rate through a named pipe: lerobot's OpenCVCamera reads a
    plain file as fast as it decodes (its thread does not pace files), so a file alone is no live camera."""
    pipe = tmp_path / "v.nut"
    os.mkfifo(pipe)
    feed(pipe, write_video(tmp_path / "source.nut"))
    spec = {"type": "opencv", "index_or_path": str(pipe), "width": W, "height": H, "warmup_s": 0}
    cam = make_cameras(HardwareConfig(driver="lerobot", robot={"type": "x"}, cameras={"front": spec}), "robot.yaml")
    camera = cam["front"]
    camera.start()
    samples: list[CameraSample] = []
    try:
        end = time.monotonic() + 1.0
        while time.monotonic() < end:
            s = camera.latest()
            if s is not None and (not samples or s.seq != samples[-1].seq):
                samples.append(s)
            time.sleep(0.001)
    finally:
        camera.stop()
    assert len(samples) >= 3
    index = []
    for s in samples:  # OpenCV decoded the file exactly: every sample IS a source frame
        k, err = nearest(s.image)
        assert err == 0.0
        index.append(k)
    assert index == sorted(index) and len(set(index)) == len(index)
    stamps = [s.stamp for s in samples]
    assert all(b > a for a, b in itertools.pairwise(stamps))


def _with_camera(path: Path, index_or_path: str) -> None:
    manifest = yaml.safe_load(path.read_text())
    manifest["hardware"]["calibration_dir"] = "calibration"
    manifest["hardware"]["cameras"] = {"front": {"type": "opencv", "index_or_path": index_or_path, "width": W,
                                                 "height": H, "warmup_s": 0}}  # fmt: skip
    path.write_text(yaml.safe_dump(manifest, sort_keys=False))


@pytest.mark.slow
def test_a_network_stream_recorded_through_the_hal_loop_counts_its_stall(
    so101: tuple[SimulatedFeetechBus, Path], tmp_path: Path
) -> None:
    bus, manifest = so101
    server = StreamServer(write_video(tmp_path / "v.nut"), stall_at=40, stall_s=1.0)
    _with_camera(manifest, server.url)
    out = tmp_path / "cam"
    try:
        s = record_hal(
            HalRecordOptions(
                robot="so101_follower", rskill="sweep-so-arm", mode="real", port=bus.port, fps=10, max_steps=25,
                out=out, codec="h264", operator="success",
            )
        )  # fmt: skip
    finally:
        server.close()
    report = s.all_reports[0]
    assert s.episodes[0].length == 25 and report.accounted()
    assert report.stale["front"] >= 5 and report.stale_ticks == report.stale["front"]  # the 1 s stall, counted
    cols = frames_table(out)
    assert sum(cols["openral.ticks_stale"]) == report.stale_ticks  # ... and visible in the frames after it
    real = np.array(cols["openral.real_timestamp"])
    assert np.all(np.diff(real) > 0)
    ages = np.array(cols["openral.sample_age.front"])
    assert np.all(ages >= 0) and np.all(ages <= 0.3 + 1e-6)  # never older than the staleness limit
    assert episode_infos(out)[0]["hal"]["stale"]["front"] == report.stale["front"]

    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    ds = LeRobotDataset("local/cam", root=out, video_backend="pyav")
    index = []
    for i in range(len(ds)):  # each recorded frame is one source frame (h264: close, not equal), in order
        img = (ds[i]["observation.images.front"].numpy().transpose(1, 2, 0) * 255).round().astype(np.uint8)
        k, err = nearest(img)
        assert err < 4.0, (i, k, err)
        index.append(k)
    assert index == sorted(index) and index[-1] - index[0] >= 20


def test_a_camera_that_cannot_be_opened_or_never_delivers_is_one_line_before_episode_0(
    so101: tuple[SimulatedFeetechBus, Path], tmp_path: Path
) -> None:
    bus, manifest = so101
    args = ["record", "--hal", "so101_follower", "--mode", "real", "--rskill", "sweep-so-arm", "--port", bus.port]
    _with_camera(manifest, str(tmp_path / "absent.nut"))
    r = run_inproc(*args, "--out", str(tmp_path / "a"))
    assert r.returncode == 2 and r.stderr.count("\n") == 1, r.stderr
    assert "hardware.cameras.front: cannot open the camera" in r.stderr
    empty = tmp_path / "empty.nut"  # a source that opens and never delivers a frame: a video's header, no frame
    empty.write_bytes(write_video(tmp_path / "one.nut", n=1)[:200])
    _with_camera(manifest, str(empty))
    with pytest.raises(HalError, match=r"hardware\.cameras\.front: (no frame within|cannot open the camera)"):
        record_hal(
            HalRecordOptions(
                robot="so101_follower", rskill="sweep-so-arm", mode="real", port=bus.port, out=tmp_path / "b"
            )
        )
    assert not (tmp_path / "a").exists() and not (tmp_path / "b").exists()
