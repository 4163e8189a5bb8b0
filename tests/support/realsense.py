"""A RealSense with no camera: an SDK recording made by pyrealsense2 itself (the tests and bench_capture.py).

`SoftwareRealSense` describes a camera: an `rs.software_device` with a depth sensor (z16, in `depth_units`
metres) and a colour sensor (rgb8), same size, rate and intrinsics, identity extrinsics, with frame makers for
each stream (source frame k -> pixels). `record_sdk` records it with `rs.recorder` (a `.db3` rosbag2 file, what
a manifest's `playback:` plays) as frames are pushed at a live camera's pace.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

Frame = Callable[[int], npt.NDArray[Any]]  # source frame k -> (H, W, 3) uint8 colour or (H, W) uint16 depth
Streams = tuple[tuple[Any, Any, Frame], ...]  # (sensor, profile, frame maker) per stream, depth first


@dataclass(frozen=True)
class SoftwareRealSense:
    """A software RealSense: its serial number, frame size and rate, frame makers and intrinsics."""

    colour: Frame
    depth: Frame
    width: int
    height: int
    rate: int
    serial: str = "123456789"
    depth_units: float = 0.001  # metres per depth unit (a D405 has 0.0001)
    fx: float = 50.0
    fy: float = 51.0
    cx: float = 31.5
    cy: float = 23.5

    def intrinsics(self) -> Any:
        import pyrealsense2 as rs

        i = rs.intrinsics()
        i.width, i.height, i.fx, i.fy, i.ppx, i.ppy = self.width, self.height, self.fx, self.fy, self.cx, self.cy
        i.model, i.coeffs = rs.distortion.brown_conrady, [0.0] * 5
        return i

    def stream(self, kind: Any, fmt: Any, bpp: int, uid: int) -> Any:
        import pyrealsense2 as rs

        s = rs.video_stream()
        s.type, s.index, s.uid, s.fmt, s.bpp = kind, 0, uid, fmt, bpp
        s.width, s.height, s.fps = self.width, self.height, self.rate
        s.intrinsics = self.intrinsics()
        return s


def software_camera(cam: SoftwareRealSense) -> tuple[Any, Streams]:
    """The `rs.software_device` of `cam` (not started); each stream as (sensor, profile, frame maker)."""
    import pyrealsense2 as rs

    dev = rs.software_device()
    dev.register_info(rs.camera_info.serial_number, cam.serial)
    dev.register_info(rs.camera_info.name, "Intel RealSense D435 (software)")
    depth_sensor, colour_sensor = dev.add_sensor("Stereo Module"), dev.add_sensor("RGB Camera")
    depth_profile = depth_sensor.add_video_stream(cam.stream(rs.stream.depth, rs.format.z16, 2, 0))
    colour_profile = colour_sensor.add_video_stream(cam.stream(rs.stream.color, rs.format.rgb8, 3, 1))
    depth_sensor.add_read_only_option(rs.option.depth_units, cam.depth_units)
    same = rs.extrinsics()
    same.rotation, same.translation = [1.0, 0, 0, 0, 1.0, 0, 0, 0, 1.0], [0.0, 0.0, 0.0]
    depth_profile.register_extrinsics_to(colour_profile, same)
    return dev, ((depth_sensor, depth_profile, cam.depth), (colour_sensor, colour_profile, cam.colour))


def push(streams: Streams, k: int, number: int, rate: int) -> None:
    """Source frame k of every stream, stamped as frame `number` at number / rate seconds."""
    import pyrealsense2 as rs

    for sensor, profile, make in streams:
        pixels = make(k)
        f = rs.software_video_frame()
        f.pixels, f.bpp = pixels, pixels.itemsize * (3 if pixels.ndim == 3 else 1)
        f.stride, f.timestamp, f.frame_number = pixels.shape[1] * f.bpp, number * 1000.0 / rate, number
        f.domain, f.profile = rs.timestamp_domain.hardware_clock, profile.as_video_stream_profile()
        sensor.on_video_frame(f)


def record_sdk(cam: SoftwareRealSense, path: Path, n: int, stall_at: int | None = None, stall_s: float = 0.0) -> Path:
    """An SDK recording of `cam` at `path`: source frames 0..n-1 pushed at its rate (the recorder stamps them as
    they arrive), pausing `stall_s` after frame `stall_at`."""
    import pyrealsense2 as rs

    dev, streams = software_camera(cam)
    recorder = rs.recorder(str(path), dev)
    sensors = recorder.query_sensors()
    for s in sensors:
        s.open(s.get_stream_profiles()[0])
        s.start(lambda frame: None)
    t0 = time.monotonic()
    for k in range(n):
        push(streams, k, k, cam.rate)
        if k == stall_at:
            t0 += stall_s
        wait = t0 + (k + 1) / cam.rate - time.monotonic()
        if wait > 0:
            time.sleep(wait)
    for s in sensors:
        s.stop()
        s.close()
    del recorder, sensors  # the recorder closes its file when it is released
    return path


def slope_mm(width: int, height: int, k: int, step: int = 25) -> npt.NDArray[np.uint16]:
    """Depth frame k (millimetres): a slope over the image, `step` mm further per frame."""
    y, x = np.mgrid[0:height, 0:width]
    return (300 + step * k + 4 * x + 3 * y).astype(np.uint16)
