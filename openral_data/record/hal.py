"""`record --hal ROBOT`: a robot behind a HAL (its MuJoCo twin, a sim scene, or the real one) recorded by the
fixed-rate loop (record/hal_loop.py) through the same bridge and sinks as `record`."""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable
from contextlib import ExitStack, closing
from dataclasses import asdict, dataclass, field, replace
from functools import partial
from pathlib import Path
from typing import Any, Literal, get_args

from openral_data import manifests
from openral_data.errors import CompatibilityError, ConfigError, UsageError
from openral_data.formats.codec import Codec
from openral_data.formats.lerobot_v3 import VideoSettings, WriterConfig, loadable
from openral_data.formats.lerobot_v3.provenance import HalOrigin, Origin, Recorded, SafetyRecord
from openral_data.formats.mcap import ImageFormat, McapCompression
from openral_data.policies.base import PolicyAdapter
from openral_data.policies.checkpoint import PolicyCheckpoint, as_rskill, load_operated, open_checkpoint
from openral_data.policies.device import resolve_device
from openral_data.policies.intervention import intervention_columns
from openral_data.producers.hal.robots.base import HalBase
from openral_data.producers.hal.robots.safety import SafetyFilter
from openral_data.producers.hal.robots.twin import MujocoTwinHal, SceneHal
from openral_data.producers.hal.session.operator import HELP as KEYS_HELP
from openral_data.producers.hal.session.operator import (
    Command,
    KeyboardOperator,
    Operator,
    ScriptedOperator,
    parse_script,
)
from openral_data.producers.hal.teleop.declare import TakeoverRule
from openral_data.producers.hal.teleop.eef_device import DeviceOperator
from openral_data.producers.hal.teleop.keyboard import tty_status
from openral_data.record.capture import SessionCapture, encoder_lag, keep_capture
from openral_data.record.drivers.base import DriveContext, Driver
from openral_data.record.drivers.choice import OWN_CONTRACT, DriverChoice, DriverKind, choose_driver
from openral_data.record.drivers.expert import EXPERT, expert_request, scene_rskill
from openral_data.record.drivers.kinds import open_driver
from openral_data.record.flow import Flow, Notify, check_reset_time, episode_ticks
from openral_data.record.hal_loop import EpisodeEnd, EpisodeReport, FixedRateLoop, LoopConfig, frame_extras
from openral_data.record.hal_resume import HAL_KEPT, continue_hal, expert_settings, hal_settings
from openral_data.record.options import check_run_numbers
from openral_data.record.output import Claim, Output, check_first_episode, claim, close_output, open_recording
from openral_data.record.realtime import DEFAULT_PRIORITY
from openral_data.record.runlog import log_episode, log_totals
from openral_data.record.session import episode_loop
from openral_data.runtime import registry
from openral_data.runtime.bridge import DatasetBridge
from openral_data.runtime.compat import check_compatibility
from openral_data.runtime.outdir import fresh_out
from openral_data.runtime.schema import check_environment_state, dataset_schema
from openral_data.runtime.sinks import OutputFormat, check_outputs
from openral_data.schemas.hal import SafetyMode
from openral_data.schemas.robot import RobotManifest
from openral_data.schemas.rskill import RSkillManifest
from openral_data.types import DatasetSchema, EpisodeRecord, FrameObserver, ProducerSpec, Sink
from openral_data.viz import DEFAULT_PORT

Mode = Literal["sim", "real"]
DEFAULT_MAX_STEPS = 200
JOINT_REPRESENTATIONS = ("joint_positions_gripper", "joint_positions")


@dataclass(frozen=True)
class HalRecordOptions:
    robot: str
    rskill: str | None  # None: --teleop leader or --policy; the robot manifest's own state/action (`teleop_rskill`)
    mode: Mode = "sim"
    fps: int = 20
    scene: str | None = None  # sim mode: drive this sim scene through the HAL instead of the bare twin
    n_episodes: int = 1
    max_steps: int | None = None  # None: the `episode_time_s` ticks, else DEFAULT_MAX_STEPS
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
    video: VideoSettings = field(default_factory=VideoSettings)  # the encoder settings; `codec` is its shorthand
    teleop: str | None = None  # a person drives instead of the rSkill's policy: keyboard, leader, gamepad[=NODE], ...
    episode_time_s: float | None = None  # each episode records this long (record/flow.py); None: to the step limit
    reset_time_s: float | None = None  # the wait between episodes to reset the scene (space skips it)
    view: bool = False  # stream the run to rerun (viz/live.py), as `record --view`
    view_port: int = DEFAULT_PORT
    view_address: str | None = None

    @property
    def step_limit(self) -> int:
        """Frames per episode at most: `max_steps`, else as many as `episode_time_s` lasts, else 200."""
        if self.max_steps is not None:
            return self.max_steps
        ticks = episode_ticks(self.episode_time_s, self.fps)
        return ticks if ticks is not None else DEFAULT_MAX_STEPS

    takeover: bool = False  # the rSkill's policy drives; the person (`teleop`) takes over and back: `t`, a button
    policy: str | None = None  # a lerobot checkpoint (folder or cached repo id) drives instead of an rSkill
    device: str | None = None  # with `policy`: cpu, cuda[:N], mps or auto (default: cpu)
    teleop_gain: float = 1.0  # a person's device moves this many times its default step (keyboard: 1 cm / press)
    expert: str | None = None  # `teleop="expert"`: the rSkill it runs (None: the scene's default rSkill)
    takeover_rule: TakeoverRule = field(default_factory=TakeoverRule)  # when the expert takes over and hands back
    realtime: int | None = None  # loop thread SCHED_FIFO priority (record/realtime.py); None: 50 in real mode; 0: off
    driver: DriverChoice = field(init=False)  # who drives: `rskill`, `policy`, `teleop` and `takeover`, chosen once
    resume: bool = False  # continue the HAL recording in `out` with its own settings (record/hal_resume.py)
    explicit: frozenset[str] = frozenset()  # the options the user gave (with resume: they must match the recording)

    def __post_init__(self) -> None:
        """`mode`, `safety` and the output settings are checked here, once, by whoever builds the options (the
        CLI, the Python API)."""
        check_outputs(self.formats, self.codec, self.image_format, self.mcap_compression)
        object.__setattr__(self, "video", VideoSettings.given(self.codec, video=self.video))  # decided once
        object.__setattr__(self, "codec", self.video.codec)
        if self.mode not in get_args(Mode):
            raise UsageError(f"--mode: {self.mode!r}; valid: {', '.join(get_args(Mode))}")
        if self.safety is not None and self.safety not in get_args(SafetyMode):
            raise UsageError(f"--safety: {self.safety!r}; valid: {', '.join(get_args(SafetyMode))}")
        driver = choose_driver(self.rskill, self.policy, self.teleop, hal=True, takeover=self.takeover)
        object.__setattr__(self, "driver", driver)
        if driver.terminal and self.operator != "keyboard":
            raise UsageError(
                f"--teleop {self.teleop}: the operator keys come from the same terminal (--operator keyboard)"
            )
        if driver.kind is DriverKind.CHECKPOINT and self.scene is not None:
            raise UsageError("--policy: not with --hal --scene (record --scene S --policy PATH records a scene)")
        if self.device is not None and self.policy is None:
            raise UsageError("--device: with --hal only for --policy (an rSkill names its own device)")
        if self.rskill is None and self.policy is None and driver.kind not in OWN_CONTRACT:
            raise UsageError("--rskill: needed (only --teleop leader records without one: the robot's own contract)")
        if not 0.1 <= self.teleop_gain <= 10 or (self.teleop_gain != 1.0 and driver.device is None):
            raise UsageError(
                f"--teleop-gain: {self.teleop_gain:g}: a number in 0.1..10, "
                "with --teleop keyboard, gamepad or spacemouse"
            )


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
    capture: SessionCapture = field(default_factory=SessionCapture)  # how the cameras' encoders kept up
    resumed_at: int = 0  # episodes the dataset held when this run started (--resume)
    recovered: tuple[str, ...] = ()  # what --resume's recovery did to what a killed run left

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
            "capture": self.capture.to_json(self.all_reports),
            "resumed_at": self.resumed_at,
            "recovered": list(self.recovered),
        }


def make_operator(spec: str, listener: Callable[[str], None] | None = None) -> Operator:
    if spec == "keyboard":
        return KeyboardOperator(listener=listener)
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
        from openral_data.producers.hal.robots.lerobot_hw import make_hardware_hal

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
                robot, rskill, env.spec, rskill_source=rskill_src, scene_source=str(scene_path), video=opts.video
            )
            check_environment_state(scene, str(scene_path), env.spec)
        except BaseException:
            env.close()
            raise
        state_names, action_names = list(rskill.state_contract.names), list(rskill.action_contract.names)
        return SceneHal(robot, env, state_names, action_names, task=scene.task.instruction)
    return MujocoTwinHal(robot)


def teleop_scene(scene: str, robot: str | None, rskill: str | None) -> tuple[str, str, int, int]:
    """`record --scene S --teleop DEVICE` is `record --hal ROBOT --scene S` with a person driving: the robot
    (`--robot`, else the scene's), the rSkill whose contract the person's actions keep (`--rskill`, else the
    scene's default), the scene's fps and the task's step limit."""
    from openral_data.record.options import rskill_ref
    from openral_data.schemas.scene import load_recordable_scene

    path = registry.resolve_scene_path(scene)
    loaded = load_recordable_scene(path)
    robot_id = robot or loaded.scene.robot
    if robot_id is None:
        raise ConfigError(f"{path}: scene.robot: not set; pass --robot (valid: {', '.join(registry.robot_ids())})")
    return robot_id, rskill_ref(rskill, loaded), loaded.scene.fps, loaded.task.max_steps


def check_hal(
    hal: HalBase, robot: RobotManifest, rskill: RSkillManifest, rskill_src: str, video: VideoSettings
) -> None:
    spec = ProducerSpec(
        state_dim=hal.state_dim,
        action_dim=hal.action_dim,
        cameras={n: c.shape for n, c in hal.cameras.items()},
        fps=1,
    )
    check_compatibility(robot, rskill, spec, rskill_source=rskill_src, scene_source=f"robot {robot.name}", video=video)


STATUS_FD = 2  # the teleoperator's status lines go to the terminal on stderr


def record_hal(opts: HalRecordOptions, notify: Notify | None = None) -> HalRecordSummary:
    """Resolve and check everything, claim `out`, open the driver, build the HAL, then open the dataset and run
    the episodes. `notify` None: the run says nothing (-q, --json): no prompts, and no teleop status lines either
    (those only ever go to a terminal on stderr). Whatever is opened is closed, in reverse order, by the stack."""
    with ExitStack() as stack:
        session = _Session()
        stack.callback(session.close)  # what was recorded stays; what a run that recorded nothing made goes
        if opts.resume:  # the recording's own settings, read under its writer lock
            if opts.out is None:
                raise UsageError("--resume needs --out: the dataset folder to continue")
            session.held = claim(opts.out, "openral-data record --hal --resume", resume=True)
            takeover = (opts.expert, opts.takeover_rule) if _expert_drives(opts) else None
            opts = replace(opts, **continue_hal(opts.out, _kept(opts), opts.explicit, opts.video, takeover))
        run = _resolve(opts)
        show = tty_status(STATUS_FD, talk=notify is not None)  # the person's status lines: when the run talks
        expert = None
        if _expert_drives(opts):
            expert = expert_request(opts.expert, opts.scene, opts.takeover_rule, run.rskill, run.rskill_src)
        ctx = DriveContext(
            run.robot, run.rskill, run.rskill_src, run.make_policy, opts.fps, show, run.checkpoint, opts.teleop_gain,
            expert,
        )  # fmt: skip
        if session.held is None:  # one writer, before any byte goes in
            session.held = claim(run.out, "openral-data record --hal", resume=False)
        driver = open_driver(opts.driver, ctx, stack)
        operator = stack.enter_context(closing(make_operator(opts.operator, driver.listener)))
        if driver.device is not None:
            operator = DeviceOperator(operator, driver.device)
        hal = stack.enter_context(closing(build_hal(opts, run.robot, run.rskill, run.rskill_src)))
        loop = _open(opts, run, hal, driver, operator, session)
        _keys_help(opts, notify, driver)
        assert session.output is not None
        return _episodes(opts, run.out, loop, notify, session.output)


@dataclass
class _Session:
    """The writer lock on `out` (`claim`) and, once the settings are stored or recovered, the opened output."""

    held: Claim | None = None
    output: Output | None = None

    def close(self) -> None:
        """Release the lock; a fresh recording that finished nothing leaves no folder behind (`close_output`)."""
        if self.output is not None:
            close_output(self.output.claim.out, self.output, 0)
        elif self.held is not None:
            self.held.release()


def _expert_drives(opts: HalRecordOptions) -> bool:
    """`--teleop expert`: the scene's scripted expert is the person who takes over (a DAgger round)."""
    return opts.driver.device is not None and opts.driver.device.name == EXPERT


def _kept(opts: HalRecordOptions) -> dict[str, Any]:
    """The values of the options a resume keeps (`HAL_KEPT`)."""
    return {name: getattr(opts, name) for name in HAL_KEPT}


def _keys_help(opts: HalRecordOptions, notify: Notify | None, driver: Driver) -> None:
    """The person's keys, said once everything is resolved and open (bad input is one `error:` line, no help)."""
    if notify is not None and opts.operator == "keyboard":
        notify(KEYS_HELP)
    if notify is not None and driver.help is not None:
        notify(driver.help)


@dataclass(frozen=True)
class _Resolved:
    robot: RobotManifest
    rskill: RSkillManifest
    rskill_src: str
    make_policy: registry.PolicyFactory
    out: Path
    checkpoint: PolicyCheckpoint | None = None  # `--policy`: the lerobot checkpoint driving instead of an rSkill


def _resolve(opts: HalRecordOptions) -> _Resolved:
    """Everything that can be wrong with the numbers, names and formats, found before anything is written."""
    if opts.fps < 1 or opts.fps > 1000:
        raise UsageError(f"--fps must be in 1..1000, got {opts.fps}")
    episode_ticks(opts.episode_time_s, opts.fps)
    check_reset_time(opts.reset_time_s)
    check_run_numbers(opts.n_episodes, opts.step_limit, opts.seed)
    if opts.view:
        from openral_data.viz.live import check_view_options

        check_view_options(opts.view_port, opts.view_address)
    if opts.staleness is not None and not 0 < opts.staleness < math.inf:
        raise UsageError(f"--staleness must be > 0 and finite, got {opts.staleness}")
    robot = registry.ROBOTS[opts.robot]
    checkpoint = None
    if opts.policy is not None:  # a lerobot checkpoint: the robot's own joints, or the scene's rSkill's contract
        device = resolve_device(opts.device) if opts.device is not None else None  # (`check_fits` on the HAL)
        checkpoint = open_checkpoint(opts.policy)
        base = registry.resolve_rskill(scene_rskill(opts.scene))[0] if opts.scene is not None else None
        rskill, rskill_src = as_rskill(checkpoint, base or teleop_rskill(robot)), str(checkpoint.config_file)
        load = registry.policy_factory(rskill, rskill_src)
        make_policy: registry.PolicyFactory = partial(load_operated, load, device=device, checkpoint=checkpoint)
    elif opts.rskill is None:  # a leader arm without --rskill: it speaks the robot's own joints
        rskill, rskill_src = teleop_rskill(robot), str(manifests.robot_file(robot.name))
        make_policy = _no_policy
    else:
        rskill, rskill_path = registry.resolve_rskill(opts.rskill)
        rskill_src = str(rskill_path)
        make_policy = registry.policy_factory(rskill, rskill_src)
    out = opts.out if opts.out is not None else fresh_out(f"hal-{robot.name}")
    return _Resolved(robot, rskill, rskill_src, make_policy, out, checkpoint)


def teleop_rskill(robot: RobotManifest) -> RSkillManifest:
    """The contract of a leader arm driving `robot`: the manifest's own state and action (joint positions)."""
    gripper = any(j.type == "gripper" for j in robot.joints)
    rep = "joint_positions_gripper" if gripper else "joint_positions"
    state, action = robot.observation.state, robot.action
    return RSkillManifest.model_validate(
        {
            "id": f"teleop-{robot.name}",
            "description": f"a person drives {robot.name} with its leader arm",
            "policy": "teleop",
            "embodiment_tags": robot.embodiment_tags or [robot.name],
            "state_contract": {"dim": state.dim, "names": state.names, "representation": rep},
            "action_contract": {"dim": action.dim, "names": action.names, "representation": rep},
        }
    )


def _no_policy(rskill: RSkillManifest) -> PolicyAdapter:
    raise ConfigError(f"rskill {rskill.id}: a teleoperator drives; there is no policy to load")


def _open(
    opts: HalRecordOptions, run: _Resolved, hal: HalBase, driver: Driver, operator: Operator, session: _Session
) -> FixedRateLoop:
    """The driver's policy, the safety filter, the dataset schema, the output (fresh: its settings stored; resume:
    checked and recovered, `session.output`), the connected HAL and the sinks, put together as the loop."""
    from openral_data.runtime.sinks import make_sinks

    robot, rskill = run.robot, run.rskill
    policy = driver.policy(hal)  # a checkpoint is checked against the HAL first
    check_hal(hal, robot, rskill, run.rskill_src, opts.video)
    safety = SafetyFilter(
        robot, mode=opts.safety, fk=hal.kinematics(), names=hal.action_names, state_names=hal.state_names,
        source=str(manifests.robot_file(robot.name)),
    )  # fmt: skip
    cameras = list(hal.cameras)
    schema = dataset_schema(
        robot,
        rskill,
        run.rskill_src,
        fps=opts.fps,
        cameras={n: hal.cameras[n].shape for n in cameras},
        origin=Origin(
            scene=_recorded_scene(opts.scene),  # a scene behind the HAL replays as that scene (`replay`)
            hal=HalOrigin(robot.name, opts.mode, type(hal).__name__, opts.scene),
            safety=SafetyRecord(safety.mode, robot.safety.model_dump(mode="json")),
        ),
        environment_state_names=hal.environment_state_names,  # a scene's object poses, as `record --scene` names them
        has_reward=hal.has_reward,
        frame_extras=frame_extras(cameras),
        frame_columns=intervention_columns(rskill.action_contract.names) if driver.takeover else (),
    )
    assert session.held is not None
    session.output = opened = open_recording(session.held, opts.resume, opts.formats, schema, _settings(opts))
    warmed = _connect(hal, policy, warm=opened.fresh and "lerobot" in opts.formats)
    observers = _observers(opts, schema)
    try:
        sinks: list[Sink] = make_sinks(
            run.out,
            schema,
            opts.formats,
            # waits on no encoder (formats/lerobot_v3/video.py) nor commit (formats/lerobot_v3/committer.py)
            WriterConfig(video=opts.video, spill=True, background=True),
            opts.image_format,
            resume=opts.resume,
            mcap_compression=opts.mcap_compression,
        )
    except BaseException:
        DatasetBridge(schema, [], observers=observers).close()  # the live view goes with the failed start
        raise
    bridge = DatasetBridge(schema, sinks, first_episode=opened.first_episode, observers=observers)
    task = hal.task if hal.task is not None else rskill.description or rskill.id
    config = _loop_config(opts, task, driver.name(policy))
    if warmed is not None:  # before the first episode: the import's CPU-seconds never compete with the loop
        warmed.join()
    return FixedRateLoop(hal, policy, safety, bridge, operator, config)


def _settings(opts: HalRecordOptions) -> dict[str, Any]:
    """What a fresh recording stores for `--resume` (record.json's `options`): the kept options and, for a DAgger
    round, its expert and takeover rule."""
    settings = hal_settings(_kept(opts), opts.n_episodes, opts.video)
    if _expert_drives(opts):
        settings["expert"] = expert_settings(opts.expert, opts.takeover_rule)
    return settings


def _loop_config(opts: HalRecordOptions, task: str, driver: str) -> LoopConfig:
    staleness = opts.staleness if opts.staleness is not None else 3.0 / opts.fps
    ticks = episode_ticks(opts.episode_time_s, opts.fps)
    realtime = opts.realtime if opts.realtime is not None else (DEFAULT_PRIORITY if opts.mode == "real" else 0)
    return LoopConfig(opts.fps, task, opts.step_limit, staleness, driver=driver, max_ticks=ticks, realtime=realtime)


def _connect(hal: HalBase, policy: PolicyAdapter, *, warm: bool) -> threading.Thread | None:
    """Connect the robot, and a leader arm (the policy's `connect`): one that cannot be reached fails here, before
    anything is written. With `warm` (a new recording's first episode will be checked loadable,
    `check_first_episode`), lerobot's import (`loadable.warm_up`) runs meanwhile on a thread of its own, as a
    scene's recording pays it beside the scene's build, instead of between the first two episodes; the caller
    joins the returned thread before the first episode."""
    warming = threading.Thread(target=loadable.warm_up, name="warm-up-lerobot", daemon=True) if warm else None
    if warming is not None:
        warming.start()
    hal.connect()
    connect = getattr(policy, "connect", None)
    if callable(connect):
        connect()
    return warming


def _observers(opts: HalRecordOptions, schema: DatasetSchema) -> list[FrameObserver]:
    """`--view`: the run live in rerun, as `record --view` shows a scene (the bridge closes it)."""
    if not opts.view:
        return []
    from openral_data.viz.live import open_live_view

    return [open_live_view(schema, port=opts.view_port, address=opts.view_address)]


def _recorded_scene(scene: str | None) -> Recorded | None:
    if scene is None:
        return None
    from openral_data.schemas.scene import load_recordable_scene

    path = registry.resolve_scene_path(scene)
    return Recorded(str(path), load_recordable_scene(path).model_dump(mode="json"))


def _episodes(
    opts: HalRecordOptions, out: Path, loop: FixedRateLoop, notify: Notify | None, opened: Output
) -> HalRecordSummary:
    """Episodes until the dataset holds `n_episodes`, the operator quits or the e-stop latches; a resumed run
    continues the numbering at `opened.first_episode`. An interactive operator starts each one (space) unless it
    is a re-record or a reset wait (`--reset-time-s`) just ended; the reset wait follows every episode but the
    last."""
    operator = loop.operator
    first = opened.first_episode
    flow = Flow(opts.n_episodes, loop.config.task, notify, opts.episode_time_s, opts.reset_time_s)
    summary = HalRecordSummary(out=out, episodes=[], reports=[], discarded=0, frames=0, seconds=0.0)
    summary.resumed_at, summary.recovered = first, tuple(opened.actions)
    t0 = time.perf_counter()
    # Ctrl-C / SIGTERM stop between ticks, never inside a commit
    with episode_loop(loop.bridge, loop.policy, out, lambda: first + loop.bridge.kept(len(summary.episodes))) as stop:
        loop.config.check_stop = stop.check
        rerecord = reset = False
        while first + len(summary.episodes) < opts.n_episodes:
            index = first + len(summary.episodes)
            if not rerecord and not (reset and operator.interactive):
                loop.preview(index, opts.seed + index)
                flow.ask_start(index, operator.interactive)
                if operator.wait_start(index, stop.check) is Command.QUIT:
                    summary.stopped_by_operator = True
                    break
            flow.started(index, again=rerecord)
            t_episode = time.perf_counter()
            end, report, rec = loop.run_episode(index, opts.seed + index)
            if rec is not None and not summary.episodes and opened.fresh:  # the first episode: `out` is a dataset
                check_first_episode(out, opts.formats, loop.bridge.close)
            rerecord = end is EpisodeEnd.RERECORD
            flow.say(
                f"{flow.name(index)}: {end.value} ({report.verdict}, {report.frames} frames, "
                f"{report.overruns} overruns, {report.stale_ticks} stale, {report.interventions} interventions)"
            )
            if not _account(summary, end, report, rec, time.perf_counter() - t_episode):
                break
            if first + len(summary.episodes) < opts.n_episodes:
                reset = flow.reset_time_s is not None
                if not _reset(summary, flow, loop, stop.check, first + len(summary.episodes)):
                    break
    summary.seconds = time.perf_counter() - t0
    for report, rec in zip(summary.reports, summary.episodes, strict=True):  # all committed now (bridge closed)
        summary.capture.add(report, encoder_lag(loop.bridge.sinks, rec.index))
    if summary.episodes and "lerobot" in opts.formats:
        keep_capture(out, summary.capture.to_json(summary.all_reports))
    log_totals(out, len(summary.episodes), summary.frames, summary.seconds)
    return summary


def _reset(summary: HalRecordSummary, flow: Flow, loop: FixedRateLoop, check: Callable[[], None], index: int) -> bool:
    """The reset wait before episode `index`; False when the run stops here (the operator quit, the e-stop)."""
    cmd = flow.reset(loop.operator, index, check)
    if cmd is Command.QUIT:
        summary.stopped_by_operator = True
    elif cmd is Command.ESTOP:
        loop.hal.estop("operator e-stop (between episodes)")
        summary.estop = loop.hal.estop_reason
        flow.say(f"e-stop: {summary.estop}")
    return cmd not in (Command.QUIT, Command.ESTOP)


def _account(
    summary: HalRecordSummary, end: EpisodeEnd, report: EpisodeReport, rec: EpisodeRecord | None, seconds: float
) -> bool:
    """An episode's end into the summary; False when the run stops here (the operator quit, the e-stop)."""
    summary.all_reports.append(report)
    if end is EpisodeEnd.QUIT:
        summary.stopped_by_operator = True
        return False
    if rec is None:
        summary.discarded += 1
        return True
    summary.episodes.append(rec)
    log_episode(rec, seconds)
    summary.reports.append(report)
    summary.frames += rec.length
    if report.estop is not None:
        summary.estop = report.estop
        return False
    return True
