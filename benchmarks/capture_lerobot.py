"""The anchor of `bench_capture.py`: lerobot 0.6.1's own recorder on the same robot and sources.

`lerobot-record`'s `record_loop` (lerobot/scripts/lerobot_record.py) with its `LeRobotDataset` writer (default: PNG
frames, then the episode's videos encoded at `save_episode`; `--streaming`: its streaming encoder, which drops
frames when it falls behind), the SO-101 follower (lerobot's `SO101Follower`) on the same simulated Feetech bus and
the same `OpenCVCamera` sources, and the same RealSense recordings through lerobot's own `RealSenseCamera`
(`use_depth=True`: its colour and its depth, unaligned, as lerobot records them; `PlaybackRealSenseCamera` only sets
the recording, looped, where lerobot names the device). lerobot's loop needs a teleoperator for actions: a minimal
one holding the arm where it is (`HoldTeleop`, the only stand-in here; lerobot's `Teleoperator` interface). A tick
that took longer than its period is an overrun (lerobot logs "Record loop is running slower"; counted here the same
way).
"""

from __future__ import annotations

import os
import time
from pathlib import Path
from typing import Any

W, H, RATE = 640, 480, 30


VCODEC = {"h264": "h264", "av1": "libsvtav1", "auto": "auto"}  # lerobot's `--dataset.rgb_encoder.vcodec`


def lerobot_session(pipes: list[str], recordings: list[tuple[str, Path]], port: str, calibration: Path,
                    seconds: float, fps: int, out: Path, codec: str, streaming: bool) -> dict[str, Any]:  # fmt: skip
    """One episode of `seconds` recorded by lerobot's `record_loop` into a new `LeRobotDataset` at `out`
    (`recordings`: each RealSense's serial number and SDK recording)."""
    from lerobot.cameras.opencv import OpenCVCamera, OpenCVCameraConfig
    from lerobot.cameras.realsense import RealSenseCameraConfig
    from lerobot.configs.video import RGBEncoderConfig
    from lerobot.datasets import LeRobotDataset, aggregate_pipeline_dataset_features, create_initial_features
    from lerobot.processor import make_default_processors
    from lerobot.robots.so_follower.so_follower import SOFollower, SOFollowerRobotConfig
    from lerobot.scripts import lerobot_record
    from lerobot.teleoperators.teleoperator import Teleoperator
    from lerobot.utils.feature_utils import combine_feature_dicts

    cameras: dict[str, Any] = {
        f"cam{i}": OpenCVCameraConfig(index_or_path=Path(p), width=W, height=H, fps=RATE, warmup_s=0)
        for i, p in enumerate(pipes)
    }
    for i, (serial, _) in enumerate(recordings):
        cameras[f"rs{i}"] = RealSenseCameraConfig(serial, fps=RATE, width=W, height=H, use_depth=True, warmup_s=0)
    config = SOFollowerRobotConfig(port=port, id="so101_follower", calibration_dir=calibration, cameras=cameras)
    robot = SOFollower(config)
    # a stream has its own size and rate, which OpenCV cannot set: the cameras are opened without asking for them
    # (as openral_data/producers/hal/robots/lerobot_hw.py does); the config keeps 640x480@30 (the video size)
    for name, cam in cameras.items():
        if isinstance(cam, OpenCVCameraConfig):
            robot.cameras[name] = OpenCVCamera(OpenCVCameraConfig(index_or_path=cam.index_or_path, warmup_s=0))
    for i, (_, path) in enumerate(recordings):
        robot.cameras[f"rs{i}"] = playback_camera()(cameras[f"rs{i}"], path)
    robot.connect(calibrate=False)
    teleop_proc, action_proc, obs_proc = make_default_processors()
    features = combine_feature_dicts(
        aggregate_pipeline_dataset_features(teleop_proc, create_initial_features(action=robot.action_features)),
        aggregate_pipeline_dataset_features(obs_proc, create_initial_features(observation=robot.observation_features)),
    )
    dataset = LeRobotDataset.create(
        "local/anchor", fps, features, root=out, robot_type=robot.name, use_videos=True,
        image_writer_threads=4 * len(cameras), rgb_encoder=RGBEncoderConfig(vcodec=VCODEC[codec]),
        streaming_encoding=streaming,
    )  # fmt: skip
    Teleoperator.register(HoldTeleop)  # lerobot's loop takes actions from a `Teleoperator` only
    hold = HoldTeleop(robot)
    slow = _SlowCounter()
    try:
        cpu0, t0 = os.times(), time.perf_counter()
        lerobot_record.record_loop(
            robot=robot, events={"exit_early": False}, fps=fps, teleop_action_processor=teleop_proc,
            robot_action_processor=action_proc, robot_observation_processor=obs_proc, dataset=dataset,
            teleop=hold, control_time_s=seconds, single_task="hold",
        )  # fmt: skip
        dataset.save_episode()
        dataset.finalize()
        frames = dataset.meta.total_frames
        cpu1, wall = os.times(), time.perf_counter() - t0
    finally:
        slow.close()
        robot.disconnect()
    return {
        "frames": int(frames),
        "ticks_due": round(seconds * fps),
        "overruns": slow.count,
        "in_video": {name: _frames(out, name) for name in robot.observation_features if name in videos(out)},
        # with more than one video lerobot's writer encodes each in a worker process: their CPU is counted too
        "cpu_s": sum(
            getattr(cpu1, f) - getattr(cpu0, f) for f in ("user", "system", "children_user", "children_system")
        ),
        "wall_s": round(wall, 1),
        "depth_videos": depth_videos(out, [f"rs{i}_depth" for i in range(len(recordings))]),
    }


def playback_camera() -> Any:
    """lerobot's `RealSenseCamera` playing an SDK recording in a loop (lerobot's pipeline otherwise)."""
    from lerobot.cameras.realsense import RealSenseCamera

    class PlaybackRealSenseCamera(RealSenseCamera):  # type: ignore[misc]
        def __init__(self, config: Any, recording: Path) -> None:
            super().__init__(config)
            self.recording = recording

        def _configure_rs_pipeline_config(self, rs_config: Any) -> None:
            super()._configure_rs_pipeline_config(rs_config)
            rs_config.enable_device_from_file(str(self.recording), True)  # repeat_playback

    return PlaybackRealSenseCamera


def videos(out: Path) -> set[str]:
    """The cameras with videos in the dataset at `out` (a RealSense's colour `rs0`, depth `rs0_depth`)."""
    return {p.name.removeprefix("observation.images.") for p in (out / "videos").iterdir()}


def depth_videos(out: Path, names: list[str]) -> dict[str, str]:
    """Each depth camera's video codec and pixel format, checked by loading the episode's last frame with lerobot
    (a (1, H, W) depth map in mm, as it loads depth)."""
    import av
    from lerobot.datasets import LeRobotDataset

    if not names:
        return {}
    try:
        ds = LeRobotDataset("local/anchor", root=out, video_backend="pyav")
        last: dict[str, Any] | str = ds[len(ds) - 1]
    except Exception as exc:  # noqa: BLE001 - e.g. its streaming encoder dropped frames: the video ends early
        last = f"lerobot cannot load its last frame: {type(exc).__name__}: {str(exc).splitlines()[0][:160]}"
    got = {}
    for name in names:
        video = next((out / "videos" / f"observation.images.{name}").rglob("*.mp4"))
        with av.open(str(video)) as c:
            s = c.streams.video[0].codec_context
            if isinstance(last, str):
                got[name] = f"{s.name} {s.pix_fmt}, {last}"
                continue
            depth = last[f"observation.images.{name}"]
            got[name] = f"{s.name} {s.pix_fmt}, loads as {tuple(depth.shape)} {depth.min():.0f}..{depth.max():.0f}"
    return got


class HoldTeleop:
    """Holds the arm where it stood at the start: the action is the first joint reading, every tick."""

    def __init__(self, robot: Any) -> None:
        obs = robot.get_observation()
        self.action = {k: float(obs[k]) for k in robot.action_features}

    def get_action(self) -> dict[str, float]:
        return dict(self.action)


class _SlowCounter:
    """Counts lerobot's 'Record loop is running slower' warnings (one per overrun)."""

    def __init__(self) -> None:
        import logging

        self.count = 0
        outer = self

        class Handler(logging.Handler):
            def emit(self, record: logging.LogRecord) -> None:
                if "running slower" in record.getMessage():
                    outer.count += 1

        self.handler = Handler()
        self.logger = logging.getLogger()
        self.logger.addHandler(self.handler)
        self._level = self.logger.level
        self.logger.setLevel(logging.WARNING if self._level > logging.WARNING or self._level == 0 else self._level)

    def close(self) -> None:
        self.logger.removeHandler(self.handler)
        self.logger.setLevel(self._level)


def _frames(out: Path, camera: str) -> int:
    import av

    total = 0
    for video in sorted((out / "videos" / f"observation.images.{camera}").rglob("*.mp4")):
        with av.open(str(video)) as c:
            total += sum(1 for p in c.demux(c.streams.video[0]) if p.size)
    return total
