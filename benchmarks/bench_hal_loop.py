"""HAL loop benchmark: what the fixed-rate loop's recording and bookkeeping cost per frame.

Workload: the UR5e MuJoCo twin (real physics in step with the monotonic clock) with its 128x128 wrist camera,
the `sweep-ur5e` policy, N frames per run. Two contestants, alternating in one process:

1. **bare** (the baseline): a tight Python loop doing only what any recorder must do per frame — read the joint
   state, take the camera sample, run the policy, send the action. Nothing is validated or written.
2. **loop**: `FixedRateLoop` at a rate it cannot reach (1000 fps, so it never sleeps) with the safety filter
   (joint, velocity and workspace limits with forward kinematics), tick/overrun/staleness accounting, the
   bridge's contract checks and the LeRobot v3 writer (h264 encoder thread, parquet, stats, durable commit).

Printed: median seconds per frame of each, the ratio loop / bare (the overhead factor) and the highest rate
the loop sustains on this machine (1 / its time per frame). Then a paced run at `--fps` that reports the
overruns the loop counted. Times vary a lot on a shared 2-core machine: compare the ratio, not the times.

Run (from the repository root)::

    MUJOCO_GL=egl .venv/bin/python benchmarks/bench_hal_loop.py                  # ~1 min
    MUJOCO_GL=egl .venv/bin/python benchmarks/bench_hal_loop.py --frames 300 --repeats 5 --fps 30
"""

from __future__ import annotations

import argparse
import json
import statistics
import tempfile
import time
from pathlib import Path

from openral_data.formats.lerobot_v3 import LeRobotV3Writer, VideoSettings, WriterConfig
from openral_data.producers.hal.robots.base import JointCommand
from openral_data.producers.hal.robots.safety import SafetyFilter
from openral_data.producers.hal.robots.twin import MujocoTwinHal
from openral_data.producers.hal.session.operator import ScriptedOperator
from openral_data.record.hal_loop import FixedRateLoop, LoopConfig, frame_extras
from openral_data.runtime import registry
from openral_data.runtime.bridge import DatasetBridge
from openral_data.types import DatasetSchema, Observation


def bare(hal: MujocoTwinHal, frames: int) -> float:
    rskill, path = registry.resolve_rskill("sweep-ur5e")
    policy = registry.policy_factory(rskill, str(path))(rskill)
    policy.reset(0)
    t0 = time.perf_counter()
    start = time.monotonic()
    for _ in range(frames):
        state = hal.read_state()
        sample = hal.cameras["wrist"].latest()
        assert sample is not None
        obs = Observation({"wrist": sample.image}, state.positions, "sweep", time=state.stamp - start)
        hal.send_action(JointCommand(policy.step(obs, "sweep")))
    return (time.perf_counter() - t0) / frames


def loop(hal: MujocoTwinHal, frames: int, fps: int, out: Path) -> tuple[float, int, int]:
    rskill, path = registry.resolve_rskill("sweep-ur5e")
    policy = registry.policy_factory(rskill, str(path))(rskill)
    schema = DatasetSchema(
        fps=fps,
        state_names=tuple(rskill.state_contract.names),
        action_names=tuple(rskill.action_contract.names),
        cameras={"wrist": hal.cameras["wrist"].shape},
        robot_type="ur5e",
        has_reward=False,
        frame_extras=frame_extras(["wrist"]),
    )
    bridge = DatasetBridge(schema, [LeRobotV3Writer(out, schema, WriterConfig(video=VideoSettings(codec="h264")))])
    safety = SafetyFilter(hal.robot, fk=hal.forward_kinematics)
    runner = FixedRateLoop(hal, policy, safety, bridge, ScriptedOperator(), LoopConfig(fps, "sweep", frames, 1.0))
    t0 = time.perf_counter()
    _, rep, rec = runner.run_episode(0, 0)
    bridge.close()
    assert rec is not None and rec.length == frames and rep.accounted()
    return (time.perf_counter() - t0) / frames, rep.overruns, rep.missed_ticks


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--frames", type=int, default=200)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--fps", type=int, default=30, help="rate of the paced run")
    args = ap.parse_args()
    hal = MujocoTwinHal(registry.ROBOTS["ur5e"])
    hal.connect()
    bare_t, loop_t = [], []
    try:
        with tempfile.TemporaryDirectory() as tmp:
            for r in range(args.repeats):
                bare_t.append(bare(hal, args.frames))
                loop_t.append(loop(hal, args.frames, 1000, Path(tmp) / f"fast{r}")[0])
            paced, overruns, missed = loop(hal, args.frames, args.fps, Path(tmp) / "paced")
    finally:
        hal.disconnect()
    b, lp = statistics.median(bare_t), statistics.median(loop_t)
    result = {
        "frames": args.frames,
        "repeats": args.repeats,
        "bare_s_per_frame": b,
        "loop_s_per_frame": lp,
        "overhead_ratio": lp / b,
        "loop_max_fps": 1 / lp,
        "paced_fps": args.fps,
        "paced_overruns": overruns,
        "paced_missed_ticks": missed,
        "paced_s_per_frame": paced,
    }
    print(json.dumps(result, indent=2))


if __name__ == "__main__":
    main()
