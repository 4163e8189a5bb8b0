"""The fixed-rate recording loop: HAL -> policy -> safety -> HAL, every tick recorded or accounted for.

Tick k of an episode is due at `t0 + k / fps` (monotonic clock). At each tick the loop reads the joint state
(`StaleState` if too old), takes each camera's newest sample and its age, and then either

* records a frame: the policy's action passes the safety filter and is sent (or refused and held), and the
  row stores the action that was actually commanded; or
* skips the tick as **stale** when the joint state or a camera sample is older than the staleness limit (the
  policy never acts on stale data; nothing is sent; the tick is counted per sensor).

A tick whose work ends after the next deadline is an **overrun**; deadlines that passed entirely are
**missed** ticks (the loop never bursts to catch up). So `ticks == frames + missed + stale` exactly, and each
frame says how many ticks were missed and how many were stale just before it. A camera sample recorded twice
is counted as a **repeat** (the sample's age is in the row): reuse of the newest sample is visible, never
silent.

Stored per frame (LeRobot: float32 columns; MCAP: the message stamps): `timestamp` stays frame-aligned
(`frame_index / fps`, what lerobot expects); `openral.real_timestamp` is the monotonic time of the joint
reading since the episode began (also `Observation.time`, the MCAP stamp); `openral.tick`,
`openral.ticks_missed`, `openral.ticks_stale`, `openral.safety_interventions` and
`openral.sample_age.<camera>`; in an intervention session (policies/intervention.py) also the policy's proposal
`openral.policy_action` and the flag `openral.intervention`; with a sim scene that declares one, its
`observation.environment_state` (object poses, `HalBase.environment_state`), given to the policy as well, as
`record --scene` gives it. The episode's report (overruns, stale and repeat counts, every safety intervention,
the operator's verdict) goes to the episode record (`openral.episode_info` in meta/episodes).
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from enum import StrEnum
from typing import Any

import numpy as np
import numpy.typing as npt

from openral_data.errors import EstopLatched, HalError, StaleState
from openral_data.policies.base import PolicyAdapter
from openral_data.policies.intervention import Intervention
from openral_data.producers.hal.robots.base import HalBase, JointCommand, Outcome, monotonic
from openral_data.producers.hal.robots.safety import SafetyFilter
from openral_data.producers.hal.session.operator import Command, Operator
from openral_data.record.realtime import RealTime
from openral_data.runtime.bridge import DatasetBridge
from openral_data.types import EpisodeRecord, Observation, Previews

REAL_TIMESTAMP = "openral.real_timestamp"
TICK = "openral.tick"
TICKS_MISSED = "openral.ticks_missed"
TICKS_STALE = "openral.ticks_stale"
SAFETY = "openral.safety_interventions"
SAMPLE_AGE = "openral.sample_age."
TIME_LIMIT = "time_limit"  # the verdict of an episode that ran its `--episode-time-s` without a verdict key
log = logging.getLogger(__name__)
MAX_LOGGED_INTERVENTIONS = 1000  # per episode in the JSON record; the per-frame column counts all of them


def frame_extras(cameras: list[str]) -> tuple[str, ...]:
    return (REAL_TIMESTAMP, TICK, TICKS_MISSED, TICKS_STALE, SAFETY, *(SAMPLE_AGE + c for c in cameras))


class EpisodeEnd(StrEnum):
    KEPT = "kept"
    DISCARDED = "discarded"
    RERECORD = "rerecord"
    QUIT = "quit"  # quit before anything was recorded in this episode (the episode in flight is discarded)


@dataclass
class EpisodeReport:
    ticks: int = 0
    frames: int = 0
    overruns: int = 0
    missed_ticks: int = 0
    stale_ticks: int = 0
    stale: dict[str, int] = field(default_factory=dict)  # sensor ("state" or a camera) -> ticks skipped
    repeated: dict[str, int] = field(default_factory=dict)  # camera -> frames that reused a recorded sample
    max_age: dict[str, float] = field(default_factory=dict)  # camera -> oldest sample recorded (s since it arrived)
    interventions: int = 0
    refused: int = 0
    intervention_log: list[dict[str, Any]] = field(default_factory=list)
    max_lateness: float = 0.0  # seconds past its deadline the latest tick started
    verdict: str = ""
    estop: str | None = None

    def to_json(self) -> dict[str, Any]:
        return asdict(self)

    def accounted(self) -> bool:
        return self.ticks == self.frames + self.missed_ticks + self.stale_ticks


@dataclass
class _Row:
    obs: Observation
    action: npt.NDArray[np.float32]
    reward: float
    success: bool
    extras: dict[str, float]
    columns: dict[str, Any] | None = None  # an intervention session's proposal and flag (policies/intervention.py)


@dataclass
class _Episode:
    """Where the episode in flight is: its clock start, the tick due, and what the next frame carries."""

    t0: float
    k: int = 0  # the tick due
    last_seq: dict[str, int] = field(default_factory=dict)  # camera -> sequence number of its last recorded sample
    pending: _Row | None = None  # the newest frame: it goes to the bridge when the next one (or the end) is known
    skipped: list[int] = field(default_factory=lambda: [0, 0])  # ticks missed / stale since the last frame


@dataclass
class LoopConfig:
    fps: int
    task: str
    max_steps: int
    staleness: float  # seconds: an older camera sample makes the tick stale
    sleep: Callable[[float], None] = time.sleep
    check_stop: Callable[[], None] | None = None  # raises (KeyboardInterrupt) to stop between ticks
    stale_abort: float = 2.0  # seconds of nothing but stale ticks: a sensor is dead, the episode is abandoned
    driver: str = "script"  # who drove (`operator` in the episode's record): policy:<rskill>, teleop:<device>
    max_ticks: int | None = None  # `--episode-time-s`: the episode ends when this many ticks were due (record/flow.py)
    realtime: int = 0  # SCHED_FIFO priority of the loop's thread during an episode (record/realtime.py); 0: normal


class FixedRateLoop:
    def __init__(
        self,
        hal: HalBase,
        policy: PolicyAdapter,
        safety: SafetyFilter,
        bridge: DatasetBridge,
        operator: Operator,
        config: LoopConfig,
    ) -> None:
        self.hal = hal
        self.policy = policy
        self.safety = safety
        self.bridge = bridge
        self.operator = operator
        self.config = config
        self.dt = 1.0 / config.fps
        self.cameras = list(bridge.schema.cameras)
        self.realtime = RealTime(config.realtime)

    def run_episode(self, episode: int, seed: int) -> tuple[EpisodeEnd, EpisodeReport, EpisodeRecord | None]:
        """Record one episode (the operator has started it). The HAL stays connected afterwards."""
        rep = self._begin(seed)
        ep = _Episode(t0=monotonic())
        verdict: Command | None = None
        promoted = self.realtime.promote()
        try:
            verdict = self._loop(episode, rep, ep)
        except EstopLatched as exc:  # latched by someone else (another thread, the driver) mid-tick
            verdict = Command.ESTOP
            rep.estop = str(exc)
            rep.ticks = ep.k  # the aborted tick recorded nothing
        except BaseException:
            self.bridge.discard_episode()
            raise
        finally:
            if promoted:
                self.realtime.demote()
        return self._finish(verdict, ep.pending, rep)

    def preview(self, episode: int, seed: int) -> None:
        """Before an operator starts episode `episode`: reset the HAL to where it will start and show the cameras
        to the observers that preview (the live view), so a person sees the scene before pressing space. Nothing
        is recorded; `run_episode` resets again (the same seed: the same start)."""
        watchers = [o for o in self.bridge.observers if isinstance(o, Previews)]
        if not watchers:
            return
        self.hal.begin_episode(seed)
        images = {}
        for name in self.cameras:
            sample = self.hal.cameras[name].latest()
            if sample is not None:
                images[name] = sample.image
        for watcher in watchers:
            watcher.preview(episode, images)

    def _begin(self, seed: int) -> EpisodeReport:
        """Reset the HAL and the policy and open the episode in the bridge; the report to fill."""
        hal = self.hal
        rep = EpisodeReport(
            stale={"state": 0, **dict.fromkeys(self.cameras, 0)},
            repeated=dict.fromkeys(self.cameras, 0),
            max_age=dict.fromkeys(self.cameras, 0.0),
        )
        # where the robot starts (manifest units): replay puts the MuJoCo twin there (producers/sim/mujoco/twin.py)
        initial = {**hal.begin_episode(seed), "state": hal.read_state().positions.tolist()}
        for name in self.cameras:  # warm up (first render / device start-up) before the clock starts
            hal.cameras[name].latest()
        self.policy.reset(seed)
        self.bridge.begin_episode(seed, initial)
        return rep

    def _loop(self, episode: int, rep: EpisodeReport, ep: _Episode) -> Command | None:
        """Tick until the operator gives a command (returned), the scene ends the task, the step limit is hit or the
        episode's time (`max_ticks`) is up."""
        cfg = self.config
        while True:
            if cfg.max_ticks is not None and ep.k >= cfg.max_ticks:  # the time ran out during an overrun
                rep.ticks = ep.k
                rep.verdict = TIME_LIMIT
                return None
            deadline = ep.t0 + ep.k * self.dt
            now = monotonic()
            if deadline > now:
                cfg.sleep(deadline - now)
            if cfg.check_stop is not None:
                cfg.check_stop()
            rep.max_lateness = max(rep.max_lateness, monotonic() - deadline)
            rep.ticks = ep.k + 1
            cmd = self.operator.poll(episode, rep.frames)
            if cmd is not None:
                rep.ticks = ep.k  # this tick was not worked on
                return cmd
            self._work(episode, rep, ep)
            outcome = self.hal.outcome()
            if outcome is not None and outcome.terminated:
                return None
            if cfg.max_ticks is not None and ep.k + 1 >= cfg.max_ticks:  # this was the last tick of its time
                rep.verdict = TIME_LIMIT
                return None
            if rep.frames >= cfg.max_steps:
                return None
            self._advance(rep, ep)

    def _work(self, episode: int, rep: EpisodeReport, ep: _Episode) -> None:
        """One tick: a frame becomes the pending row (the one before it goes to the bridge), or the tick is stale;
        a sensor stale for longer than `stale_abort` abandons the episode."""
        cfg = self.config
        stale_before = rep.stale_ticks
        row = self._tick(rep, ep)
        ep.skipped[1] += rep.stale_ticks - stale_before
        if ep.skipped[1] * self.dt > cfg.stale_abort:
            dead = sorted(n for n, c in rep.stale.items() if c)
            raise HalError(
                f"robot {self.hal.robot.name}: no fresh sample from {', '.join(dead)} for {cfg.stale_abort:.1f} s "
                f"(staleness limit {cfg.staleness:.3f} s); episode {episode} abandoned",
                code="hal.camera",
            )
        if row is not None:
            pending = ep.pending
            if pending is not None:
                self.bridge.add_step(
                    pending.obs, pending.action, reward=pending.reward, done=False,
                    success=pending.success, extras=pending.extras, columns=pending.columns,
                )  # fmt: skip
            ep.pending = row
            ep.skipped = [0, 0]

    def _advance(self, rep: EpisodeReport, ep: _Episode) -> None:
        """On to the next tick; one whose work ended past the next deadline is an overrun, and the deadlines
        that passed meanwhile are missed (never worked off in a burst)."""
        end = monotonic()
        next_k = ep.k + 1
        if end > ep.t0 + next_k * self.dt:
            rep.overruns += 1
            late_k = max(next_k, math.floor((end - ep.t0) / self.dt))
            rep.missed_ticks += late_k - next_k
            ep.skipped[0] += late_k - next_k
            next_k = late_k
        ep.k = next_k

    def _tick(self, rep: EpisodeReport, ep: _Episode) -> _Row | None:
        hal, cfg = self.hal, self.config
        k, t0, last_seq, skipped = ep.k, ep.t0, ep.last_seq, ep.skipped
        try:
            state = hal.read_state()
        except StaleState:
            rep.stale["state"] += 1
            rep.stale_ticks += 1
            return None
        sampled = self._samples(rep, last_seq)
        if sampled is None:
            return None
        images, ages = sampled
        obs = Observation(
            images, state.positions, cfg.task, time=state.stamp - t0, privileged=hal.privileged(),
            environment_state=hal.environment_state(),
        )  # fmt: skip
        action = self.policy.step(obs, cfg.task)
        columns = self.policy.columns() if isinstance(self.policy, Intervention) else None
        self.bridge.check_action(action)
        result = self.safety.apply(action, state.positions, self.dt)
        for item in result.interventions:
            if len(rep.intervention_log) < MAX_LOGGED_INTERVENTIONS:
                rep.intervention_log.append({"frame": rep.frames, "tick": k, **item.to_json()})
        rep.interventions += len(result.interventions)
        if result.applied is None:
            rep.refused += 1
            sent = self._held(state.positions, action)
        else:
            sent = hal.send_action(JointCommand(result.applied)).positions
        outcome = hal.outcome()
        reward, success = (outcome.reward, outcome.success) if outcome is not None else (0.0, False)
        extras = {
            REAL_TIMESTAMP: state.stamp - t0,
            TICK: float(k),
            TICKS_MISSED: float(skipped[0]),
            TICKS_STALE: float(skipped[1]),
            SAFETY: float(len(result.interventions)),
            **{SAMPLE_AGE + n: a for n, a in ages.items()},
        }
        rep.frames += 1
        return _Row(obs, np.asarray(sent, dtype=np.float32).copy(), reward, success, extras, columns)

    def _samples(
        self, rep: EpisodeReport, last_seq: dict[str, int]
    ) -> tuple[dict[str, npt.NDArray[np.uint8]], dict[str, float]] | None:
        """Each camera's newest sample and its age; None (a stale tick, counted) when one is missing or older than
        the staleness limit. A sample the previous frame recorded again is counted as a repeat."""
        now = monotonic()
        images: dict[str, npt.NDArray[np.uint8]] = {}
        ages: dict[str, float] = {}
        stale = []
        seqs: dict[str, int] = {}
        for name in self.cameras:
            sample = self.hal.cameras[name].latest()
            if sample is None or now - sample.stamp > self.config.staleness:
                stale.append(name)
                continue
            images[name] = sample.image
            ages[name] = max(0.0, now - sample.stamp)
            seqs[name] = sample.seq
        if stale:
            for name in stale:
                rep.stale[name] += 1
            rep.stale_ticks += 1
            return None
        for name, seq in seqs.items():
            if last_seq.get(name) == seq:
                rep.repeated[name] += 1
            last_seq[name] = seq
            rep.max_age[name] = max(rep.max_age[name], ages[name])
        return images, ages

    def _held(self, state: npt.NDArray[np.float32], action: npt.NDArray[np.float32]) -> npt.NDArray[np.float32]:
        """What the robot keeps doing when a command is refused: its last command (else its current position)."""
        last = self.hal.last_command
        if last is not None:
            return last.positions
        cur = self.safety.current(state)
        return np.where(np.isnan(cur), action, cur).astype(np.float32)

    def _finish(
        self, verdict: Command | None, pending: _Row | None, rep: EpisodeReport
    ) -> tuple[EpisodeEnd, EpisodeReport, EpisodeRecord | None]:
        if verdict is None:
            verdict = self.operator.at_end()
        if verdict in (Command.DISCARD, Command.RERECORD, Command.QUIT) or pending is None:
            self.bridge.discard_episode()
            rep.verdict = (verdict or Command.DISCARD).value if pending is not None else "empty"
            end = {Command.RERECORD: EpisodeEnd.RERECORD, Command.QUIT: EpisodeEnd.QUIT}.get(
                verdict or Command.DISCARD, EpisodeEnd.DISCARDED
            )
            return end, rep, None
        if verdict is Command.ESTOP:
            if not self.hal.estopped:
                self.hal.estop("operator e-stop")
            rep.estop = rep.estop or self.hal.estop_reason
        outcome = self.hal.outcome()
        success: bool | None
        if verdict is Command.SUCCESS:
            success = True
        elif verdict in (Command.FAILURE, Command.ESTOP):
            success = False
        elif outcome is not None:
            success = bool(outcome.success)
        else:
            success = None  # ran to the step limit and nobody said how it went
        if verdict is not None:
            rep.verdict = verdict.value
        elif outcome is not None and outcome.terminated:
            rep.verdict = "scene"
        elif rep.verdict != TIME_LIMIT:
            rep.verdict = "scene" if outcome is not None else "step_limit"
        self.bridge.add_step(
            pending.obs, pending.action, reward=pending.reward, done=True,
            success=bool(success) if success is not None else pending.success, extras=pending.extras,
            columns=pending.columns,
        )  # fmt: skip
        judged = judgement(verdict, outcome if self.hal.has_reward else None)
        info = {"hal": rep.to_json(), "operator": self.config.driver, **judged}
        record = self.bridge.end_episode(success, info=info)[0]
        return EpisodeEnd.KEPT, rep, record


def judgement(verdict: Command | None, outcome: Outcome | None) -> dict[str, Any]:
    """Who said how the episode went: `operator_verdict` (`success`/`failure`, None: the operator said neither)
    and `scene_success` (the scene's own criterion at the last frame; None: the HAL has none). The recorded success
    is the operator's when given; a verdict the scene's criterion contradicts is said at once (a warning)."""
    said = verdict.value if verdict in (Command.SUCCESS, Command.FAILURE) else None
    scene = bool(outcome.success) if outcome is not None else None
    if said is not None and scene is not None and (said == Command.SUCCESS.value) != scene:
        log.warning(
            "the operator marked the episode %s; the scene's success criterion says %s (the operator's verdict is "
            "recorded, with both in openral.episode_info)",
            said,
            "successful" if scene else "not successful",
            extra={"operator_verdict": said, "scene_success": scene},
        )
    return {"operator_verdict": said, "scene_success": scene}
