"""Helpers for the HAL tests: the UR5e twin, a real slow camera, a slow policy, and the loop on real sinks."""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
import pyarrow.parquet as pq
import yaml

from openral_data.formats.lerobot_v3 import LeRobotV3Writer, VideoSettings, WriterConfig
from openral_data.formats.mcap import McapSink
from openral_data.policies.base import PolicyAdapter
from openral_data.producers.hal.cameras.sensors import ThreadedCamera
from openral_data.producers.hal.robots.safety import SafetyFilter
from openral_data.producers.hal.robots.twin import MujocoTwinHal
from openral_data.producers.hal.session.operator import Operator
from openral_data.record.hal_loop import EpisodeEnd, EpisodeReport, FixedRateLoop, LoopConfig, frame_extras
from openral_data.runtime import registry
from openral_data.runtime.bridge import DatasetBridge
from openral_data.types import CameraShape, DatasetSchema, FrameColumn, Observation, Sink


def ur5e_twin(**kwargs: Any) -> MujocoTwinHal:
    return MujocoTwinHal(registry.ROBOTS["ur5e"], **kwargs)


class SlowCamera(ThreadedCamera):
    """A camera whose device needs `period` seconds per image; image k is solid grey level 10 k (mod 260),
    coarse enough that a lossy codec cannot merge neighbours."""

    def __init__(self, name: str, period: float, shape: CameraShape | None = None) -> None:
        self.count = 0
        self.period = period
        super().__init__(name, shape or CameraShape(32, 32), self._capture)

    def _capture(self) -> npt.NDArray[np.uint8]:
        time.sleep(self.period)
        img = np.full((self.shape.height, self.shape.width, 3), 10 * (self.count % 26), dtype=np.uint8)
        self.count += 1
        return img


class SlowPolicy:
    """Wraps a policy; the steps listed in `slow_steps` take `delay` seconds (a heavy model's hiccups)."""

    def __init__(self, inner: PolicyAdapter, slow_steps: set[int], delay: float) -> None:
        self.inner = inner
        self.slow_steps = slow_steps
        self.delay = delay
        self.calls = 0

    def reset(self, seed: int) -> None:
        self.inner.reset(seed)

    def step(self, observation: Observation, instruction: str) -> npt.NDArray[np.float32]:
        if self.calls in self.slow_steps:
            time.sleep(self.delay)
        self.calls += 1
        return self.inner.step(observation, instruction)

    def close(self) -> None:
        self.inner.close()


def run_loop(
    hal: MujocoTwinHal,
    policy: PolicyAdapter,
    operator: Operator,
    out: Path,
    *,
    fps: int = 20,
    max_steps: int = 20,
    staleness: float = 0.15,
    episodes: int = 1,
    safety: SafetyFilter | None = None,
    columns: tuple[FrameColumn, ...] = (),
    mcap: Path | None = None,
    writer: WriterConfig | None = None,
    realtime: int = 0,
) -> list[tuple[EpisodeEnd, EpisodeReport]]:
    """Record `episodes` attempts through the loop into a LeRobot v3 dataset at `out` (`writer`, default h264 for
    speed), and with `mcap` into MCAP bags there too (as `record --format lerobot,mcap`)."""
    rskill, _ = registry.resolve_rskill("sweep-ur5e")
    cams = list(hal.cameras)
    schema = DatasetSchema(
        fps=fps,
        state_names=tuple(rskill.state_contract.names),
        action_names=tuple(rskill.action_contract.names),
        cameras={n: hal.cameras[n].shape for n in cams},
        robot_type="ur5e",
        has_reward=False,
        frame_extras=frame_extras(cams),
        frame_columns=columns,
    )
    sinks: list[Sink] = [LeRobotV3Writer(out, schema, writer or WriterConfig(video=VideoSettings(codec="h264")))]
    if mcap is not None:
        sinks.append(McapSink(mcap, schema))
    bridge = DatasetBridge(schema, sinks)
    filt = safety or SafetyFilter(hal.robot, fk=hal.forward_kinematics)
    loop = FixedRateLoop(
        hal, policy, filt, bridge, operator, LoopConfig(fps, "sweep", max_steps, staleness, realtime=realtime)
    )
    results = []
    hal.connect()
    try:
        for e in range(episodes):
            operator.wait_start(e)
            end, rep, _ = loop.run_episode(e, e)
            results.append((end, rep))
    finally:
        bridge.close()
        hal.disconnect()
    return results


def frames_table(root: Path) -> dict[str, list[Any]]:
    files = sorted((root / "data").rglob("*.parquet"))
    return pq.read_table(files[0]).to_pydict() if len(files) == 1 else {}


def episode_infos(root: Path) -> list[dict[str, Any]]:
    files = sorted((root / "meta" / "episodes").rglob("*.parquet"))
    rows = pq.read_table(files[0]).to_pydict()
    return [json.loads(s) for s in rows["openral.episode_info"]]


def calibrated_leader_manifest(path: Path, leader_port: str) -> Path:
    """The `driver: lerobot` manifest at `path` with `calibration_dir: calibration` (beside it) for its robot and
    its teleoperator, the leader on `leader_port`."""
    manifest = yaml.safe_load(path.read_text())
    manifest["hardware"]["robot"]["calibration_dir"] = "calibration"
    manifest["hardware"]["teleop"].update({"port": leader_port, "calibration_dir": "calibration"})
    path.write_text(yaml.safe_dump(manifest, sort_keys=False))
    return path
