"""`record --hal ROBOT`: a robot behind a HAL (its MuJoCo twin, a sim scene, or the real one) recorded by the
fixed-rate loop (record/hal_loop.py) through the same bridge and sinks as `record`."""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Literal, get_args

from openral_data import manifests
from openral_data.errors import CompatibilityError, ConfigError, UsageError
from openral_data.formats.codec import Codec
from openral_data.formats.lerobot_v3 import VideoSettings, WriterConfig
from openral_data.formats.lerobot_v3.provenance import HalOrigin, Origin, SafetyRecord
from openral_data.formats.mcap import ImageFormat, McapCompression
from openral_data.policies.base import PolicyAdapter
from openral_data.producers.hal.base import HalBase
from openral_data.producers.hal.operator import Command, KeyboardOperator, Operator, ScriptedOperator, parse_script
from openral_data.producers.hal.safety import SafetyFilter
from openral_data.producers.hal.twin import MujocoTwinHal, SceneHal
from openral_data.record.hal_loop import EpisodeEnd, EpisodeReport, FixedRateLoop, LoopConfig, frame_extras
from openral_data.record.options import check_run_numbers
from openral_data.record.output import claim
from openral_data.record.runlog import log_episode, log_totals
from openral_data.record.session import episode_loop
from openral_data.runtime import registry
from openral_data.runtime.bridge import DatasetBridge
from openral_data.runtime.compat import check_compatibility
from openral_data.runtime.outdir import fresh_out
from openral_data.runtime.schema import dataset_schema
from openral_data.runtime.sinks import OutputFormat, check_outputs
from openral_data.schemas.hal import SafetyMode
from openral_data.schemas.robot import RobotManifest
from openral_data.schemas.rskill import RSkillManifest
from openral_data.types import EpisodeRecord, ProducerSpec, Sink

Mode = Literal["sim", "real"]
JOINT_REPRESENTATIONS = ("joint_positions_gripper", "joint_positions")


@dataclass(frozen=True)
class HalRecordOptions:
    robot: str
    rskill: str
    mode: Mode = "sim"
    fps: int = 20
    scene: str | None = None  # sim mode: drive this sim scene through the HAL instead of the bare twin
    n_episodes: int = 1
    max_steps: int = 200
    seed: int = 0
    out: Path | None = None
    codec: Codec = "av1"
    formats: tuple[OutputFormat, ...] = ("lerobot",)
    image_format: ImageFormat = "jpeg"
    mcap_compression: McapCompression = "zstd"
    operator: str = "auto"  # auto | keyboard | a script such as "success@40,discard@10"
    safety: SafetyMode | None = None  # default: the manifest's safety.mode
    staleness: float | None = None  # camera sample age limit (s); default: 3 periods
    port: str | None = None  # real mode: override the manifest's hardware.port

    def __post_init__(self) -> None:
        """`mode`, `safety` and the output settings are checked here, once, by whoever builds the options (the
        CLI, the Python API)."""
        check_outputs(self.formats, self.codec, self.image_format, self.mcap_compression)
        if self.mode not in get_args(Mode):
            raise UsageError(f"--mode: {self.mode!r}; valid: {', '.join(get_args(Mode))}")
        if self.safety is not None and self.safety not in get_args(SafetyMode):
            raise UsageError(f"--safety: {self.safety!r}; valid: {', '.join(get_args(SafetyMode))}")


@dataclass
class HalRecordSummary:
    out: Path
    episodes: list[EpisodeRecord]
    reports: list[EpisodeReport]  # kept episodes, same order
    discarded: int
    frames: int
    seconds: float
    estop: str | None = None
    stopped_by_operator: bool = False
    all_reports: list[EpisodeReport] = field(default_factory=list)  # discarded attempts too

    @property
    def overruns(self) -> int:
        return sum(r.overruns for r in self.all_reports)

    @property
    def missed_ticks(self) -> int:
        return sum(r.missed_ticks for r in self.all_reports)

    @property
    def stale_ticks(self) -> int:
        return sum(r.stale_ticks for r in self.all_reports)

    @property
    def interventions(self) -> int:
        return sum(r.interventions for r in self.all_reports)

    @property
    def repeated_samples(self) -> int:
        return sum(sum(r.repeated.values()) for r in self.all_reports)

    def to_json(self) -> dict[str, object]:
        """The fields of `record --hal --json` (less the CLI's `fps`), in docs/scripting.md's order."""
        return {
            "out": str(self.out),
            "episodes": len(self.episodes),
            "discarded": self.discarded,
            "frames": self.frames,
            "successes": sum(e.success is True for e in self.episodes),
            "seconds": self.seconds,
            "overruns": self.overruns,
            "missed_ticks": self.missed_ticks,
            "stale_ticks": self.stale_ticks,
            "repeated_samples": self.repeated_samples,
            "safety_interventions": self.interventions,
            "verdicts": [r.verdict for r in self.reports],
            "estop": self.estop,
            "stopped_by_operator": self.stopped_by_operator,
            "episode_list": [asdict(e) for e in self.episodes],
        }


def make_operator(spec: str) -> Operator:
    if spec == "keyboard":
        return KeyboardOperator()
    if spec == "auto":
        return ScriptedOperator()
    return ScriptedOperator(parse_script(spec))


def build_hal(opts: HalRecordOptions, robot: RobotManifest, rskill: RSkillManifest, rskill_src: str) -> HalBase:
    """The HAL for `--mode` (and `--scene`), checked against the rSkill before anything is written."""
    robot_src = str(manifests.robot_file(robot.name))
    if opts.scene is None and rskill.action_contract.representation not in JOINT_REPRESENTATIONS:
        raise CompatibilityError(
            f"{rskill_src}: action_contract.representation: {rskill.action_contract.representation!r}; a HAL takes "
            f"joint targets ({', '.join(JOINT_REPRESENTATIONS)})"
        )
    if opts.mode == "real":
        if opts.scene is not None:
            raise ConfigError("--scene: only with --mode sim (a real robot has no scene to simulate)")
        from openral_data.producers.hal.so100 import make_hardware_hal

        return make_hardware_hal(robot, robot_src, port=opts.port)
    if opts.scene is not None:
        from openral_data.schemas.scene import load_recordable_scene

        scene_path = registry.resolve_scene_path(opts.scene)
        scene = load_recordable_scene(scene_path)
        if scene.scene.fps != opts.fps:
            raise ConfigError(f"{scene_path}: scene.fps: {scene.scene.fps} but --fps is {opts.fps}; make them equal")
        env = registry.scene_factory(scene.scene.type, str(scene_path))(scene, robot, rskill, str(scene_path))
        try:
            check_compatibility(
                robot, rskill, env.spec, rskill_source=rskill_src, scene_source=str(scene_path), video=VideoSettings()
            )
        except BaseException:
            env.close()
            raise
        state_names, action_names = list(rskill.state_contract.names), list(rskill.action_contract.names)
        return SceneHal(robot, env, state_names, action_names, task=scene.task.instruction)
    return MujocoTwinHal(robot)


def check_hal(hal: HalBase, robot: RobotManifest, rskill: RSkillManifest, rskill_src: str, codec: Codec) -> None:
    spec = ProducerSpec(
        state_dim=hal.state_dim,
        action_dim=hal.action_dim,
        cameras={n: c.shape for n, c in hal.cameras.items()},
        fps=1,
    )
    check_compatibility(
        robot, rskill, spec, rskill_source=rskill_src, scene_source=f"robot {robot.name}", video=VideoSettings(codec)
    )


Notify = Callable[[str], None]  # one line for the operator: which episode, what happened to it


def record_hal(opts: HalRecordOptions, notify: Notify | None = None) -> HalRecordSummary:
    """Resolve and check everything, claim `out`, build the HAL, then open the dataset and run the episodes."""
    run = _resolve(opts)
    held = claim(run.out, "openral-data record --hal", resume=False)  # one writer, before any byte goes into `out`
    try:
        operator = make_operator(opts.operator)
        try:
            hal = build_hal(opts, run.robot, run.rskill, run.rskill_src)
            try:
                loop = _open(opts, run, hal, run.make_policy(run.rskill), operator)
                return _episodes(opts, run.out, loop, notify)
            finally:
                hal.close()
        finally:
            operator.close()
    finally:
        held.release()  # what was recorded stays; empty folders the claim made go


@dataclass(frozen=True)
class _Resolved:
    robot: RobotManifest
    rskill: RSkillManifest
    rskill_src: str
    make_policy: registry.PolicyFactory
    out: Path


def _resolve(opts: HalRecordOptions) -> _Resolved:
    """Everything that can be wrong with the numbers, names and formats, found before anything is written."""
    if opts.fps < 1 or opts.fps > 1000:
        raise UsageError(f"--fps must be in 1..1000, got {opts.fps}")
    check_run_numbers(opts.n_episodes, opts.max_steps, opts.seed)
    if opts.staleness is not None and not 0 < opts.staleness < math.inf:
        raise UsageError(f"--staleness must be > 0 and finite, got {opts.staleness}")
    robot = registry.ROBOTS[opts.robot]
    rskill, rskill_path = registry.resolve_rskill(opts.rskill)
    rskill_src = str(rskill_path)
    make_policy = registry.policy_factory(rskill, rskill_src)
    out = opts.out if opts.out is not None else fresh_out(f"hal-{robot.name}--{rskill.id}")
    return _Resolved(robot, rskill, rskill_src, make_policy, out)


def _open(
    opts: HalRecordOptions, run: _Resolved, hal: HalBase, policy: PolicyAdapter, operator: Operator
) -> FixedRateLoop:
    """The safety filter, the dataset schema, the connected HAL and the sinks, put together as the loop."""
    from openral_data.runtime.sinks import make_sinks

    robot, rskill = run.robot, run.rskill
    check_hal(hal, robot, rskill, run.rskill_src, opts.codec)
    safety = SafetyFilter(
        robot,
        mode=opts.safety,
        fk=hal.kinematics(),
        names=hal.action_names,
        state_names=hal.state_names,
        source=str(manifests.robot_file(robot.name)),
    )
    cameras = list(hal.cameras)
    schema = dataset_schema(
        robot,
        rskill,
        run.rskill_src,
        fps=opts.fps,
        cameras={n: hal.cameras[n].shape for n in cameras},
        origin=Origin(
            hal=HalOrigin(robot.name, opts.mode, type(hal).__name__, opts.scene),
            safety=SafetyRecord(safety.mode, robot.safety.model_dump(mode="json")),
        ),
        has_reward=hal.has_reward,
        frame_extras=frame_extras(cameras),
    )
    hal.connect()  # a robot that cannot be reached fails here, before anything is written
    sinks: list[Sink] = make_sinks(
        run.out,
        schema,
        opts.formats,
        WriterConfig(video=VideoSettings(codec=opts.codec)),
        opts.image_format,
        mcap_compression=opts.mcap_compression,
    )
    bridge = DatasetBridge(schema, sinks)
    task = hal.task if hal.task is not None else rskill.description or rskill.id
    staleness = opts.staleness if opts.staleness is not None else 3.0 / opts.fps
    return FixedRateLoop(hal, policy, safety, bridge, operator, LoopConfig(opts.fps, task, opts.max_steps, staleness))


def _episodes(opts: HalRecordOptions, out: Path, loop: FixedRateLoop, notify: Notify | None) -> HalRecordSummary:
    """Episodes until `n_episodes` are kept, the operator quits or the e-stop latches; each one the operator
    starts (an interactive one is asked first, except to re-record)."""
    operator = loop.operator
    summary = HalRecordSummary(out=out, episodes=[], reports=[], discarded=0, frames=0, seconds=0.0)
    t0 = time.perf_counter()
    # Ctrl-C / SIGTERM stop between ticks, never inside a commit
    with episode_loop(loop.bridge, loop.policy, out, lambda: len(summary.episodes)) as stop:
        loop.config.check_stop = stop.check
        rerecord = False
        while len(summary.episodes) < opts.n_episodes:
            index = len(summary.episodes)
            if notify is not None and operator.interactive and not rerecord:
                notify(f"episode {index}: press space to start (q quits)")
            if not rerecord and operator.wait_start(index, stop.check) is Command.QUIT:
                summary.stopped_by_operator = True
                break
            t_episode = time.perf_counter()
            end, report, rec = loop.run_episode(index, opts.seed + index)
            summary.all_reports.append(report)
            rerecord = end is EpisodeEnd.RERECORD
            if notify is not None:
                notify(
                    f"episode {index}: {end.value} ({report.verdict}, {report.frames} frames, "
                    f"{report.overruns} overruns, {report.stale_ticks} stale, {report.interventions} interventions)"
                )
            if end is EpisodeEnd.QUIT:
                summary.stopped_by_operator = True
                break
            if rec is None:
                summary.discarded += 1
                continue
            summary.episodes.append(rec)
            log_episode(rec, time.perf_counter() - t_episode)
            summary.reports.append(report)
            summary.frames += rec.length
            if report.estop is not None:
                summary.estop = report.estop
                break
    summary.seconds = time.perf_counter() - t0
    log_totals(out, len(summary.episodes), summary.frames, summary.seconds)
    return summary
