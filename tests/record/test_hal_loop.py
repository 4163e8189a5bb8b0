"""The fixed-rate loop on the UR5e MuJoCo twin: operator verdicts, timestamps, tick accounting, and a slow
sensor + a slow policy that must show up as stale ticks, repeats and overruns — never as silent gaps."""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
import time
from itertools import pairwise
from pathlib import Path
from typing import cast

import av
import numpy as np
import numpy.typing as npt
import pytest

from openral_data.errors import EstopLatched, HalError, OpenralError, UsageError
from openral_data.policies.base import PolicyAdapter
from openral_data.producers.hal.robots.base import JointCommand
from openral_data.producers.hal.robots.safety import SafetyFilter
from openral_data.producers.hal.session.operator import ScriptedOperator, parse_script
from openral_data.record.hal import HalRecordOptions
from openral_data.record.hal_loop import EpisodeEnd
from openral_data.runtime import registry
from openral_data.types import Observation
from tests.support.cli import run_cli
from tests.support.hal import SlowCamera, SlowPolicy, episode_infos, frames_table, run_loop, ur5e_twin
from tests.support.timing import TIMED

pytestmark = TIMED


def _sweep() -> object:
    rskill, path = registry.resolve_rskill("sweep-ur5e")
    return registry.policy_factory(rskill, str(path))(rskill)


def _check_ticks(cols: dict[str, list[float]], fps: int) -> None:
    """Within each episode: frame timestamps are frame-aligned; the tick column, the missed/stale counts and
    the real monotonic timestamps agree with each other."""
    eps = np.asarray(cols["episode_index"])
    for e in np.unique(eps):
        sel = eps == e
        frame = np.asarray(cols["frame_index"])[sel]
        ts = np.asarray(cols["timestamp"])[sel]
        assert np.allclose(ts, frame / fps, atol=1e-6)
        tick = np.asarray(cols["openral.tick"])[sel]
        skipped = np.asarray(cols["openral.ticks_missed"])[sel] + np.asarray(cols["openral.ticks_stale"])[sel]
        assert np.array_equal(np.diff(tick) - 1, skipped[1:]), "a gap in the ticks nobody accounted for"
        assert skipped[0] == tick[0]
        real = np.asarray(cols["openral.real_timestamp"])[sel]
        assert np.all(np.diff(real) > 0)
        # each frame's joint reading was taken at or after its tick's deadline, and before the next one
        assert np.all(real >= tick / fps - 1e-4)


def test_operator_verdicts_and_frame_aligned_timestamps(tmp_path: Path) -> None:
    hal = ur5e_twin()  # the manifest's wrist camera, rendered by MuJoCo
    op = ScriptedOperator(parse_script("success@8,discard@3,rerecord@2,failure"))
    out = tmp_path / "ds"
    results = run_loop(hal, _sweep(), op, out, fps=20, max_steps=10, episodes=4)  # type: ignore[arg-type]
    assert [end for end, _ in results] == [EpisodeEnd.KEPT, EpisodeEnd.DISCARDED, EpisodeEnd.RERECORD, EpisodeEnd.KEPT]
    assert [r.frames for _, r in results] == [8, 3, 2, 10]
    for _, rep in results:
        assert rep.accounted(), rep
    cols = frames_table(out)
    assert list(np.unique(cols["episode_index"])) == [0, 1]
    assert sum(1 for e in cols["episode_index"] if e == 0) == 8
    _check_ticks(cols, 20)
    # the recorded action is what was sent: inside the joint limits, steps within the velocity limit
    assert np.all(np.asarray(cols["openral.sample_age.wrist"]) < 0.15)
    infos = episode_infos(out)
    assert [i["hal"]["verdict"] for i in infos] == ["success", "failure"]
    assert [i["hal"]["frames"] for i in infos] == [8, 10]
    from pyarrow import parquet as pq

    ep = pq.read_table(next((out / "meta" / "episodes").rglob("*.parquet"))).to_pydict()
    assert ep["openral.success"] == [True, False]
    done = np.asarray(cols["next.done"])
    assert done.sum() == 2 and done[7] and done[-1]


def test_slow_sensor_and_slow_policy_are_reported_not_hidden(tmp_path: Path) -> None:
    hal = ur5e_twin(cameras=[])
    slow = SlowCamera("slow", period=0.3)  # 3.3 Hz camera, 20 Hz loop, 0.1 s staleness limit
    hal.cameras["slow"] = slow
    policy = SlowPolicy(_sweep(), slow_steps={3, 8}, delay=0.17)  # type: ignore[arg-type]
    out = tmp_path / "ds"
    [(end, rep)] = run_loop(hal, policy, ScriptedOperator(), out, fps=20, max_steps=12, staleness=0.1)
    assert end is EpisodeEnd.KEPT and rep.frames == 12
    assert rep.accounted(), rep
    assert rep.overruns >= 2 and rep.missed_ticks >= 4, rep  # 0.17 s of work in a 0.05 s period: >= 2 missed
    assert rep.stale["slow"] > 0 and rep.stale_ticks == sum(rep.stale.values()), rep
    assert rep.repeated["slow"] > 0, rep

    cols = frames_table(out)
    _check_ticks(cols, 20)
    assert int(sum(cols["openral.ticks_missed"])) == rep.missed_ticks
    assert int(sum(cols["openral.ticks_stale"])) == rep.stale_ticks
    assert max(cols["openral.sample_age.slow"]) <= 0.1 + 1e-6, "a frame used a sample beyond the limit"
    # the slow policy's ticks are the ones followed by missed ticks
    missed_at = [i for i, m in enumerate(cols["openral.ticks_missed"]) if m > 0]
    assert {4, 9} <= set(missed_at), missed_at

    # decoded video: each recorded image is a camera sample (its grey level is the sample number); reused
    # samples are exactly the repeats the report counted, and no sample number goes backwards
    video = next((out / "videos").rglob("*.mp4"))
    with av.open(str(video)) as container:
        levels = [round(float(f.to_ndarray(format="rgb24").mean()) / 10) for f in container.decode(video=0)]
    assert len(levels) == 12
    assert all(b >= a for a, b in pairwise(levels)), levels
    assert sum(1 for a, b in pairwise(levels) if a == b) == rep.repeated["slow"], levels
    infos = episode_infos(out)
    assert infos[0]["hal"]["stale"]["slow"] == rep.stale["slow"]


@pytest.mark.slow  # a subprocess recording: ~5 s alone, far more on a loaded machine
def test_cli_records_through_the_twin(tmp_path: Path, project: Path) -> None:
    out = tmp_path / "cli"
    r = run_cli(
        "record", "--hal", "ur5e", "--rskill", "sweep-ur5e", "--fps", "20", "--max-steps", "6",
        "--n-episodes", "2", "--operator", "success@4,discard@2", "--codec", "h264", "--out", str(out),
        env={"MUJOCO_GL": "egl"},
    )  # fmt: skip
    assert r.returncode == 0, r.stderr
    assert "2 kept, 1 discarded" in r.stdout
    assert "overruns" in r.stdout and "safety interventions" in r.stdout
    cols = frames_table(out)
    assert len(cols["index"]) == 4 + 6
    # the session's capture report (kept episodes' frames per camera) stays with the dataset
    capture = json.loads((out / "meta/openral.json").read_text())["capture"]
    assert capture["cameras"]["wrist"]["frames"] == 10 and capture["cameras"]["wrist"]["spilled"] >= 0
    spilled = capture["cameras"]["wrist"]["spilled"]  # and the printed summary says it, a line per camera
    line = rf"camera wrist +10 frames, {spilled} spilled to disk, oldest sample \d+ ms, longest encoder wait [\d.]+ s"
    assert re.search(line, r.stdout), r.stdout
    # nothing is overwritten: the same --out again is refused
    again = run_cli("record", "--hal", "ur5e", "--rskill", "sweep-ur5e", "--out", str(out))
    assert again.returncode == 2 and "refusing to overwrite" in again.stderr


def test_cli_error_is_one_line(tmp_path: Path, project: Path) -> None:
    r = run_cli("record", "--hal", "nosuch", "--rskill", "sweep-ur5e", "--out", str(tmp_path / "o"))
    assert r.returncode == 2 and r.stderr.strip().splitlines() == [r.stderr.strip()], r.stderr
    assert (
        r.stderr.startswith("error: unknown robot 'nosuch'; valid: ") and "in all: openral-data list robots" in r.stderr
    )
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--hal", "ur5e", "--rskill", "sweep-ur5e", "--mode", "real"], "hardware: robot 'ur5e' has no hardware"),
        (["--hal", "ur5e", "--rskill", "sweep-so-arm"], "embodiment_tags"),
        (["--hal", "ur5e", "--rskill", "scripted-push"], "a HAL takes joint targets"),
        (["--hal", "ur5e", "--rskill", "sweep-ur5e", "--operator", "win@3"], "unknown verdict"),
        (["--hal", "ur5e", "--rskill", "sweep-ur5e", "--safety", "maybe"], "--safety"),
        (["--hal", "ur5e", "--rskill", "sweep-ur5e", "--fps", "0"], "--fps"),
        (["--hal", "aloha", "--rskill", "sweep-ur5e"], "has no MuJoCo wiring"),  # the SO arms have a twin now
        (["--mode", "real"], "--mode: only with --hal"),
        (["--fps", "20", "--mode", "sim"], "--mode, --fps: only with --hal"),  # given, even at the default value
        (["--hal", "ur5e", "--rskill", "sweep-ur5e", "--mode", "twin"], "--mode: 'twin'; valid: sim, real"),
    ],
)
def test_cli_errors_name_the_problem(tmp_path: Path, project: Path, args: list[str], message: str) -> None:
    """In-process through the typer app (the entry point's one-line printing is covered above)."""
    from typer.testing import CliRunner

    from openral_data.cli.app import app

    result = CliRunner().invoke(app, ["record", *args, "--out", str(tmp_path / "o")])
    assert isinstance(result.exception, OpenralError), result.output
    assert message in str(result.exception) and "\n" not in str(result.exception)
    assert not (tmp_path / "o").exists()


def test_hal_options_check_mode_and_safety_when_built() -> None:
    """The Python API gets the CLI's checks: the options object refuses what the layers below never re-check."""
    with pytest.raises(UsageError, match=r"^--mode: 'twin'; valid: sim, real$"):
        HalRecordOptions(robot="ur5e", rskill="sweep-ur5e", mode="twin")  # type: ignore[arg-type]
    with pytest.raises(UsageError, match=r"^--safety: 'maybe'; valid: clamp, refuse$"):
        HalRecordOptions(robot="ur5e", rskill="sweep-ur5e", safety="maybe")  # type: ignore[arg-type]


class JumpPolicy:
    """Commands the home posture with the shoulder 1 rad away: far beyond one period at the velocity limit."""

    def reset(self, seed: int) -> None:
        self.target: np.ndarray | None = None

    def step(self, observation: Observation, instruction: str) -> np.ndarray:
        if self.target is None:
            self.target = np.asarray(observation.state, dtype=np.float32).copy()
            self.target[0] += 1.0
        return self.target.copy()

    def close(self) -> None:
        pass


@pytest.mark.parametrize("mode", ["clamp", "refuse"])
def test_safety_interventions_are_in_the_episode_record(tmp_path: Path, mode: str) -> None:
    hal = ur5e_twin(cameras=[])
    robot = hal.robot.model_copy(update={"safety": hal.robot.safety.model_copy(update={"mode": mode})})
    filt = SafetyFilter(robot, fk=hal.forward_kinematics)
    out = tmp_path / mode
    [(_, rep)] = run_loop(hal, JumpPolicy(), ScriptedOperator(), out, fps=20, max_steps=8, safety=filt)  # type: ignore[arg-type]
    cols = frames_table(out)
    state = np.asarray(cols["observation.state"])
    action = np.asarray(cols["action"])
    per_frame = np.asarray(cols["openral.safety_interventions"])
    assert per_frame.sum() == rep.interventions and rep.interventions >= 5
    assert per_frame[0] == 1
    log = episode_infos(out)[0]["hal"]["intervention_log"]
    assert {(i["kind"], i["name"]) for i in log} == {("velocity_limit", "shoulder_pan_joint")}
    assert all(i["commanded"] == pytest.approx(state[0, 0] + 1.0, abs=1e-4) for i in log)
    if mode == "clamp":
        # what was sent (and stored) never asks for more than the velocity limit allows in one period
        step = np.abs(action[:, 0] - state[:, 0])
        assert np.all(step <= 3.14 / 20 + 1e-4), step
        assert state[-1, 0] > state[0, 0] + 0.2  # and the arm did move toward the target
        assert all(i["applied"] is not None for i in log)
    else:
        assert rep.refused == 8 and all(i["applied"] is None for i in log)
        assert abs(state[-1, 0] - state[0, 0]) < 0.01  # nothing was sent: the arm stayed
        assert np.allclose(action[:, 0], state[0, 0], atol=0.01)  # the stored action is the hold it kept


def test_operator_estop_keeps_the_episode_and_latches(tmp_path: Path) -> None:
    hal = ur5e_twin(cameras=[])
    out = tmp_path / "estop"
    [(end, rep)] = run_loop(hal, _sweep(), ScriptedOperator(parse_script("estop@3")), out, max_steps=10)  # type: ignore[arg-type]
    assert end is EpisodeEnd.KEPT and rep.frames == 3 and rep.estop == "operator e-stop"
    info = episode_infos(out)[0]["hal"]
    assert info["verdict"] == "estop" and info["estop"] == "operator e-stop"
    from pyarrow import parquet as pq

    assert pq.read_table(next((out / "meta" / "episodes").rglob("*.parquet")))["openral.success"].to_pylist() == [False]
    hal.connect()
    try:
        with pytest.raises(EstopLatched) as excinfo:
            hal.send_action(JointCommand(hal.read_state().positions))
        assert excinfo.value.code == "hal.estop"
    finally:
        hal.disconnect()


@pytest.mark.slow  # a subprocess recording: ~5 s alone, far more on a loaded machine
def test_ctrl_c_keeps_finished_episodes(tmp_path: Path, project: Path) -> None:
    out = tmp_path / "int"
    proc = subprocess.Popen(
        [sys.executable, "-m", "openral_data.cli", "record", "--hal", "ur5e", "--rskill", "sweep-ur5e", "--fps", "20",
         "--n-episodes", "3", "--max-steps", "100000", "--operator", "success@5", "--codec", "h264", "--out", str(out)],
        env={**os.environ, "MUJOCO_GL": "egl"}, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    deadline = time.monotonic() + 120
    while not (out / "meta" / "info.json").exists() and time.monotonic() < deadline:
        time.sleep(0.2)
    time.sleep(0.5)  # well into the second (endless) episode
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err
    assert "finished episodes are kept" in err
    cols = frames_table(out)
    assert set(cols["episode_index"]) == {0} and len(cols["index"]) == 5


def test_a_dead_camera_abandons_the_episode_with_an_error(tmp_path: Path) -> None:
    hal = ur5e_twin(cameras=[])
    hal.cameras["dead"] = SlowCamera("dead", period=2.0)  # its first image comes long after the abort
    rskill, _ = registry.resolve_rskill("sweep-ur5e")
    from openral_data.formats.lerobot_v3 import LeRobotV3Writer, VideoSettings, WriterConfig
    from openral_data.record.hal_loop import FixedRateLoop, LoopConfig, frame_extras
    from openral_data.runtime.bridge import DatasetBridge
    from openral_data.types import DatasetSchema

    schema = DatasetSchema(
        fps=20,
        state_names=tuple(rskill.state_contract.names),
        action_names=tuple(rskill.action_contract.names),
        cameras={"dead": hal.cameras["dead"].shape},
        robot_type="ur5e",
        frame_extras=frame_extras(["dead"]),
    )
    writer = LeRobotV3Writer(tmp_path / "d", schema, WriterConfig(video=VideoSettings(codec="h264")))
    bridge = DatasetBridge(schema, [writer])
    loop = FixedRateLoop(
        hal, _sweep(), SafetyFilter(hal.robot, fk=hal.forward_kinematics), bridge, ScriptedOperator(),  # type: ignore[arg-type]
        LoopConfig(20, "sweep", 10, 0.1, stale_abort=0.5),
    )  # fmt: skip
    hal.connect()
    try:
        # the code says a camera went stale; which camera and after how long is the wording's job
        with pytest.raises(HalError, match=r"no fresh sample from dead for 0\.5 s") as excinfo:
            loop.run_episode(0, 0)
        assert excinfo.value.code == "hal.camera"
    finally:
        bridge.close()
        hal.disconnect()
        hal.cameras["dead"].stop()
    assert not (tmp_path / "d").exists()  # nothing half-written remains


class _SchedulingProbe:
    """Wraps a policy (called on the loop's thread each tick): the thread's scheduling policy at each step, and that
    of a thread started from it."""

    def __init__(self, inner: object) -> None:
        self.inner = cast(PolicyAdapter, inner)
        self.seen: list[int] = []
        self.child: list[int] = []

    def reset(self, seed: int) -> None:
        self.inner.reset(seed)

    def step(self, observation: Observation, instruction: str) -> npt.NDArray[np.float32]:
        from openral_data.record.realtime import policy

        self.seen.append(policy())
        if not self.child:
            import threading

            t = threading.Thread(target=lambda: self.child.append(policy()))
            t.start()
            t.join()
        return self.inner.step(observation, instruction)

    def close(self) -> None:
        self.inner.close()


@pytest.mark.skipif(not hasattr(os, "SCHED_FIFO"), reason="SCHED_FIFO is Linux's")
def test_the_loop_thread_is_real_time_during_an_episode_only(tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    """With `realtime` the loop's thread runs SCHED_FIFO while the episode records (a thread it starts does not
    inherit it), and the normal policy before and after; where the system refuses (an out-of-range priority here;
    no CAP_SYS_NICE for a user) the episode records at the normal policy and the refusal is said once."""
    from openral_data.record.realtime import RealTime, policy

    allowed = RealTime(1).promote()
    if allowed:
        RealTime(1).demote()
    probe = _SchedulingProbe(_sweep())
    hal = ur5e_twin(cameras=[])
    [(end, rep)] = run_loop(hal, probe, ScriptedOperator(), tmp_path / "a", max_steps=4, realtime=50)
    assert end is EpisodeEnd.KEPT and rep.frames == 4
    assert policy() == os.SCHED_OTHER  # demoted when the episode ended
    if allowed:  # root (CI) or a user with an RLIMIT_RTPRIO
        assert set(probe.seen) == {os.SCHED_FIFO} and probe.child == [os.SCHED_OTHER]
    else:
        assert set(probe.seen) == {os.SCHED_OTHER}
    probe = _SchedulingProbe(_sweep())
    results = run_loop(
        ur5e_twin(cameras=[]), probe, ScriptedOperator(), tmp_path / "b", max_steps=3, episodes=2, realtime=500
    )
    assert [r.frames for _, r in results] == [3, 3] and set(probe.seen) == {os.SCHED_OTHER}
    refusals = [r for r in caplog.records if "real-time priority refused" in r.getMessage()]
    assert len(refusals) == 1, refusals  # said once, not every episode
