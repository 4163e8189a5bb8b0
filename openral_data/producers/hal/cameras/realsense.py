"""RealSense cameras on the robot: lerobot 0.6.1's `RealSenseCamera` (pyrealsense2) behind the HAL.

A manifest camera `{type: intelrealsense, serial_number_or_name: ..., width, height, fps, use_depth: true}` (lerobot's
`RealSenseCameraConfig` fields, validated by lerobot) records its colour stream as camera `<name>` and, with
`use_depth`, its depth stream **aligned to the colour stream** (the SDK's `rs.align`, applied to every frameset
lerobot's read thread takes) as the depth camera `<name>_depth`: (H, W) uint16 millimetres (the device's depth
scale applied), written as lerobot depth video exactly like sim depth. Colour and depth come from one SDK
frameset, read on one capture thread of ours and stamped when lerobot's read returned; both features' `info`
carry the colour stream's intrinsics as `camera_info` (ROS CameraInfo fields) and `intrinsics` (aligned depth
has the colour camera's geometry), read from the stream the pipeline started.

`playback: PATH` (ours; not passed to lerobot) plays an SDK recording (the `.db3` pyrealsense2 2.59's
`rs.recorder` writes) through lerobot's own pipeline instead of a device (`rs.config.enable_device_from_file`,
in real time, once): the serial number must be the recording's. `playback_repeat: true` (ours) plays it in a
loop (the SDK's `repeat_playback`): a short recording stands in for a long session. At each restart the SDK
numbers and stamps the frames from the start again (its frame numbers and timestamps go back; ours are taken
when lerobot's read returns and keep increasing), and the pipeline may complete the first framesets of a pass
with the previous pass's last colour frame (its syncer matches by timestamp; lerobot's own camera sees the same).

The seams into lerobot's class are two overrides of its pipeline steps, in a subclass: the pipeline config
(the recording) and the frameset its read thread receives (the alignment). lerobot's connect retries and
USB-resets a device that does not deliver at once; ours connects without its warm-up, and waits for the first
frame itself (`LerobotCamera.start`), so a camera that never delivers is one line.
"""

from __future__ import annotations

import threading
from functools import cache
from pathlib import Path
from typing import Any

import numpy as np

from openral_data.errors import ConfigError, HalError, install_hint
from openral_data.producers.hal.cameras.sensors import CameraSample, Image, LerobotCamera
from openral_data.schemas.hal import LerobotDevice
from openral_data.types import CameraShape

TYPE = "intelrealsense"  # lerobot's registered name of RealSenseCameraConfig
PLAYBACK = "playback"
REPEAT = "playback_repeat"
OURS = (PLAYBACK, REPEAT)  # manifest fields of ours, not lerobot's (not passed to its config)
MM_PER_METRE = 1000.0
WAIT_MS = 100  # a capture waiting for a frameset checks this often whether it is being stopped


def depth_name(camera: str) -> str:
    """The depth stream of RealSense camera `camera` (`wrist` -> `wrist_depth`), as a sim camera's depth."""
    return f"{camera}_depth"


@cache
def camera_class() -> Any:
    """lerobot's `RealSenseCamera` with depth aligned to colour and an optional recording to play."""
    import pyrealsense2 as rs  # ImportError without the 'realsense' extra: `make_realsense` says so
    from lerobot.cameras.realsense import RealSenseCamera

    class AlignedRealSenseCamera(RealSenseCamera):  # type: ignore[misc]
        def __init__(self, config: Any, playback: str | None, repeat: bool = False) -> None:
            super().__init__(config)
            self.playback = playback
            self.repeat = repeat
            self.align = rs.align(rs.stream.color) if self.use_rgb and self.use_depth else None

        def _configure_rs_pipeline_config(self, rs_config: Any) -> None:
            super()._configure_rs_pipeline_config(rs_config)
            if self.playback is not None:
                rs_config.enable_device_from_file(self.playback, self.repeat)  # in real time, once or looping

        def _read_from_hardware(self) -> Any:
            frames = super()._read_from_hardware()
            return frames if self.align is None else self.align.process(frames)

    return AlignedRealSenseCamera


def camera_info(profile: Any, frame_id: str) -> dict[str, Any]:
    """A feature's `camera_info` and `intrinsics` from an SDK video stream profile's intrinsics."""
    import pyrealsense2 as rs

    i = profile.as_video_stream_profile().get_intrinsics()
    fx, fy, cx, cy = float(i.fx), float(i.fy), float(i.ppx), float(i.ppy)
    model = "equidistant" if i.model == rs.distortion.kannala_brandt4 else "plumb_bob"
    return {
        "camera_info": {
            "frame_id": frame_id,
            "width": int(i.width),
            "height": int(i.height),
            "distortion_model": model,
            "d": [float(c) for c in i.coeffs],
            "k": [fx, 0.0, cx, 0.0, fy, cy, 0.0, 0.0, 1.0],
            "r": [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
            "p": [fx, 0.0, cx, 0.0, 0.0, fy, cy, 0.0, 0.0, 0.0, 1.0, 0.0],
        },
        "intrinsics": {"fx": fx, "fy": fy, "cx": cx, "cy": cy, "model": str(i.model).split(".")[-1]},
    }


class DepthStream:
    """The aligned depth of a `RealSenseCapture`: the depth of the frameset whose colour the capture handed out
    last (same stamp and number), so a loop that reads the colour and then the depth gets one frameset. The
    colour camera owns the device: starting and stopping this one does nothing."""

    def __init__(self, name: str, shape: CameraShape, capture: RealSenseCapture) -> None:
        self.name = name
        self.shape = shape
        self.capture = capture

    def start(self) -> None:
        pass

    def stop(self) -> None:
        pass

    def latest(self) -> CameraSample | None:
        return self.capture.latest_depth()


class RealSenseCapture(LerobotCamera):
    """The colour stream of a RealSense (and its aligned depth, `depth`), one frameset per capture."""

    def __init__(self, name: str, shape: CameraShape, device: Any, source: str, field: str) -> None:
        super().__init__(name, shape, device, source, field)
        depth_shape = CameraShape(shape.height, shape.width, "mm")
        self.depth = DepthStream(depth_name(name), depth_shape, self) if device.use_depth else None
        self.depth_scale = 0.001  # metres per depth unit (read from the device when it connects)
        self._pending: Image | None = None  # the depth of the frameset being read (capture thread only)
        self._pair_lock = threading.Lock()
        self._pair: tuple[CameraSample, CameraSample | None] | None = None  # the newest (colour, depth)
        self._handed: CameraSample | None = None  # the depth of the colour `latest()` returned last

    def open_device(self) -> None:
        import pyrealsense2 as rs

        self.device.connect(warmup=False)  # our start() waits for the first frame (see the module's doc)
        profile = self.device.rs_profile
        info = camera_info(profile.get_stream(rs.stream.color), self.name)
        self.shape.info.update(info)  # the features are built from the shapes after the HAL connects
        if self.depth is not None:
            self.depth.shape.info.update({**info, "camera_info": {**info["camera_info"], "frame_id": self.depth.name}})
            self.depth_scale = float(profile.get_device().first_depth_sensor().get_depth_scale())

    def read_frame(self) -> Image:
        """The colour of lerobot's next frameset (its depth is kept for `publish`), taken together under
        lerobot's lock; waits in short slices so that `stop()` never waits for a silent device."""
        while True:
            try:
                self.device.async_read(timeout_ms=WAIT_MS)  # a frameset not yet taken, else the next one
                break
            except TimeoutError:
                if self.stopping:
                    raise
        with self.device.frame_lock:
            colour, depth = self.device.latest_color_frame, self.device.latest_depth_frame
        if colour is None or (self.depth is not None and depth is None):
            raise HalError(f"{self.source}: {self.field}: the camera stopped", code="hal.camera")
        self._pending = None if depth is None else self.millimetres(np.asarray(depth))
        return self.checked(np.array(colour, copy=True))  # see `millimetres`

    def millimetres(self, depth: Any) -> Any:
        """lerobot's (H, W, 1) depth in device units -> (H, W) uint16 millimetres, a copy: lerobot's arrays are
        views of the SDK's frames, which come from small pools (the aligner's, the device's): a sample the writer
        still holds must not hold one (with a dozen held, `rs.align` fails with "Out of frame resources")."""
        raw = depth.reshape(depth.shape[0], depth.shape[1])
        if abs(self.depth_scale - 0.001) < 1e-9:
            return np.array(raw, dtype=np.uint16, copy=True)
        mm = np.rint(raw.astype(np.float64) * (self.depth_scale * MM_PER_METRE))
        return mm.clip(0, np.iinfo(np.uint16).max).astype(np.uint16)

    def publish(self, sample: CameraSample) -> None:
        depth = None if self._pending is None else CameraSample(self._pending, sample.stamp, sample.seq)
        with self._pair_lock:
            self._pair = (sample, depth)

    def latest(self) -> CameraSample | None:
        with self._pair_lock:
            if self._pair is None:
                return None
            self._handed = self._pair[1]
            return self._pair[0]

    def latest_depth(self) -> CameraSample | None:
        with self._pair_lock:
            if self._handed is not None:
                return self._handed
            return None if self._pair is None else self._pair[1]


def make_realsense(
    name: str, spec: LerobotDevice, shape: CameraShape, source: str, field: str, config: Any
) -> RealSenseCapture:
    """The capture of manifest camera `name` (`config`: lerobot's config of `spec` without our fields, `OURS`)."""
    if not config.use_rgb:
        raise ConfigError(f"{source}: {field}.use_rgb: must be true (depth is aligned to the colour stream)")
    if int(config.rotation) != 0:
        raise ConfigError(f"{source}: {field}.rotation: not supported (the intrinsics are the sensor's, unrotated)")
    playback = spec.get(PLAYBACK)
    if playback is not None:
        if not isinstance(playback, str) or not playback:
            raise ConfigError(f"{source}: {field}.{PLAYBACK}: a path to an SDK recording, got {playback!r}")
        path = Path(playback).expanduser()
        path = path if path.is_absolute() else Path(source).parent / path  # relative to the manifest
        if not path.is_file():
            raise ConfigError(f"{source}: {field}.{PLAYBACK}: no recording {path}")
        playback = str(path)
    repeat = spec.get(REPEAT, False)
    if not isinstance(repeat, bool):
        raise ConfigError(f"{source}: {field}.{REPEAT}: true or false, got {repeat!r}")
    if repeat and playback is None:
        raise ConfigError(f"{source}: {field}.{REPEAT}: repeats a `{PLAYBACK}:` recording, and there is none")
    try:
        device = camera_class()(config, playback, repeat)
    except ImportError:
        raise ConfigError(
            f"{source}: {field}.type: {TYPE} needs the 'realsense' extra: {install_hint('realsense')}"
        ) from None
    except (ValueError, RuntimeError) as exc:  # a name no connected camera has (lerobot resolves names)
        raise HalError(f"{source}: {field}.serial_number_or_name: {exc}", code="hal.camera") from None
    return RealSenseCapture(name, shape, device, source, field)
