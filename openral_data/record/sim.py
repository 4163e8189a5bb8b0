"""`record`: scene + rSkill (+ robot) -> producer -> bridge -> sinks, one episode at a time."""

from __future__ import annotations

import signal
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from datetime import datetime
from pathlib import Path

from openral_data import __version__, paths
from openral_data.errors import ConfigError, OpenralError, OutputExists, UsageError
from openral_data.formats.lerobot_v3 import VideoSettings, WriterConfig
from openral_data.formats.lerobot_v3.video import Codec
from openral_data.formats.mcap import McapSink
from openral_data.policies.base import PolicyAdapter
from openral_data.record import registry
from openral_data.record.bridge import DatasetBridge
from openral_data.record.compat import check_compatibility
from openral_data.schemas.scene import SimScene, load_recordable_scene
from openral_data.types import DatasetSchema, EpisodeRecord, SimRollout, Sink


@dataclass(frozen=True)
class RecordOptions:
    scene: str = paths.DEFAULT_SCENE
    rskill: str = "random-mock"
    robot: str | None = None
    n_episodes: int | None = None
    seed: int | None = None
    max_steps: int | None = None
    out: Path | None = None
    codec: Codec = "av1"
    formats: tuple[str, ...] = ("lerobot",)  # any of FORMATS; see sinks.select.make_sinks for the layout
    image_format: str = "jpeg"  # MCAP camera messages: jpeg | png | raw
    resume: bool = False  # continue the recording in `out` with its own settings (see openral_data.record.output)
    explicit: frozenset[str] = frozenset()  # options the user gave (with resume: they must match the recording)
    first_episode: int = 0  # MCAP bags are numbered from here (a `--workers` share; see openral_data/parallel)


@dataclass(frozen=True)
class RecordSummary:
    out: Path
    episodes: list[EpisodeRecord]
    frames: int
    seconds: float
    resumed_at: int = 0  # episodes the dataset already held when this run started (--resume)
    recovered: tuple[str, ...] = ()  # what recovery did before resuming
    codec: str = ""  # the settings used (with --resume: the recording's own)
    formats: tuple[str, ...] = ()

    @property
    def success_rate(self) -> float:
        wins = sum(bool(e.success) for e in self.episodes if e.success is not None)
        return wins / len(self.episodes) if self.episodes else 0.0

    @property
    def fps(self) -> float:
        return self.frames / self.seconds if self.seconds > 0 else 0.0


ProgressFn = Callable[[EpisodeRecord | None, int, int], None]  # (finished episode | None at start, frames, total)


class _StopRequest:
    """Ctrl-C / SIGTERM ask the recording to stop at the next step boundary, never inside a commit.

    The loop then raises KeyboardInterrupt where nothing is half-written: the episode in flight is discarded
    and every finished one stays. A second Ctrl-C interrupts at once.
    """

    def __init__(self) -> None:
        self._requested = False
        self._previous: dict[int, object] = {}
        if threading.current_thread() is threading.main_thread():
            for sig in (signal.SIGINT, signal.SIGTERM):
                self._previous[sig] = signal.signal(sig, self._handle)

    def _handle(self, signum: int, frame: object) -> None:
        if self._requested and signum == signal.SIGINT:
            raise KeyboardInterrupt
        self._requested = True

    def check(self) -> None:
        if self._requested:
            raise KeyboardInterrupt

    def restore(self) -> None:
        for sig, handler in self._previous.items():
            signal.signal(sig, handler)  # type: ignore[arg-type]
        self._previous.clear()


def default_out(scene: SimScene, rskill_id: str) -> Path:
    return fresh_out(f"{scene.scene.id}--{rskill_id}")


def fresh_out(prefix: str) -> Path:
    """A folder under datasets/ named `<prefix>--<time stamp>` that does not exist yet."""
    stamp = datetime.now().strftime("%Y%m%d-%H%M%S")
    base = paths.datasets_dir() / f"{prefix}--{stamp}"
    out, k = base, 1
    while out.exists():
        k += 1
        out = base.with_name(f"{base.name}-{k}")
    return out


def check_out(out: Path) -> None:
    if out.exists() and not out.is_dir():
        raise OutputExists(f"{out}: --out exists and is not a directory")
    if out.is_dir() and any(out.iterdir()):
        if (out / "meta" / "info.json").exists() or (out / ".openral" / "record.json").exists():
            raise OutputExists(
                f"{out}: --out already holds a dataset; refusing to overwrite it (choose a new --out, or --resume)"
            )
        raise OutputExists(f"{out}: --out exists, is not empty and is not a dataset; refusing to write there")


def record(opts: RecordOptions, progress: ProgressFn | None = None) -> RecordSummary:
    from openral_data.record import output as resume

    if opts.resume:
        opts = resume.continue_options(opts, opts.explicit)
    # 1. everything that can be wrong with the inputs is found here, before anything is written
    scene_path = registry.resolve_scene_path(opts.scene)
    scene = load_recordable_scene(scene_path)
    scene_src = str(scene_path)
    rskill, rskill_path = registry.resolve_rskill(opts.rskill)
    rskill_src = str(rskill_path)
    if opts.robot is not None and scene.scene.fixed_robot and opts.robot != scene.scene.robot:
        raise ConfigError(
            f"{scene_src}: scene.fixed_robot: this scene is defined for robot {scene.scene.robot!r} only; "
            f"--robot {opts.robot} is refused (use a free-robot scene such as scenes/sim/ to change the robot)"
        )
    robot_id = opts.robot or scene.scene.robot
    if robot_id is None:
        raise ConfigError(f"{scene_src}: scene.robot: not set; pass --robot (valid: {', '.join(registry.robot_ids())})")
    robot = registry.ROBOTS[robot_id]
    make_policy = registry.policy_factory(rskill, rskill_src)
    make_scene = registry.scene_factory(scene.scene.type, scene_src)
    n_episodes = opts.n_episodes if opts.n_episodes is not None else scene.n_episodes
    base_seed = opts.seed if opts.seed is not None else scene.seed
    max_steps = opts.max_steps if opts.max_steps is not None else scene.task.max_steps
    if n_episodes < 1:
        raise UsageError(f"--n-episodes must be >= 1, got {n_episodes}")
    if max_steps < 1:
        raise UsageError(f"--max-steps must be >= 1, got {max_steps}")
    if base_seed < 0:
        raise UsageError(f"--seed must be >= 0, got {base_seed}")
    from openral_data.record.sinks import check_formats, make_sinks

    check_formats(opts.formats, opts.image_format)
    out = opts.out if opts.out is not None else default_out(scene, rskill.id)
    if not opts.resume:
        check_out(out)
    kept = {
        "scene": str(scene_path.resolve()),
        "rskill": str(rskill_path.resolve()),
        "robot": opts.robot,
        "seed": base_seed,
        "max_steps": max_steps,
        "codec": opts.codec,
        "formats": list(opts.formats),
        "image_format": opts.image_format,
        "n_episodes": n_episodes,
    }

    env = make_scene(scene, robot, rskill, scene_src)
    try:
        video = VideoSettings(codec=opts.codec)
        check_compatibility(robot, rskill, env.spec, rskill_source=rskill_src, scene_source=scene_src, video=video)
        policy = make_policy(rskill)
        schema = DatasetSchema(
            fps=env.spec.fps,
            state_names=tuple(rskill.state_contract.names),
            action_names=tuple(rskill.action_contract.names),
            cameras=dict(env.spec.cameras),
            robot_type=robot.name,
            metadata={
                "openral_data_version": __version__,
                "scene": {"path": scene_src, "config": scene.model_dump(mode="json")},
                "rskill": {"path": rskill_src, "config": rskill.model_dump(mode="json")},
                "robot": robot.name,
            },
        )
        output = resume.open_output(out, opts, schema, kept)
        records: list[EpisodeRecord] = []
        try:
            first = output.first_episode
            sinks: list[Sink] = make_sinks(
                out, schema, opts.formats, WriterConfig(video=video), opts.image_format, resume=opts.resume
            )
            for sink in sinks:
                if isinstance(sink, McapSink):
                    sink.index_offset = opts.first_episode
            bridge = DatasetBridge(schema, sinks, first_episode=first)
            start_at = getattr(env, "start_at", None)  # producers that number their episodes (the mock)
            if callable(start_at):
                start_at(first)
            frames = 0
            t0 = time.perf_counter()
            stop = _StopRequest()
            if progress is not None:
                progress(None, 0, max(0, n_episodes - first))
            try:
                for e in range(first, n_episodes):
                    rec = _record_episode(env, policy, bridge, base_seed + e, max_steps, stop)
                    records.append(rec)
                    frames += rec.length
                    if progress is not None:
                        progress(rec, frames, max(0, n_episodes - first))
            except BaseException as exc:
                bridge.close()  # discards the episode in flight; finished episodes are already durable
                if isinstance(exc, OpenralError) and first + len(records):
                    raise exc.amended(f"{exc} ({first + len(records)} finished episode(s) kept in {out})") from None
                raise
            finally:
                stop.restore()
                policy.close()
            bridge.close()
        finally:
            resume.close_output(out, output, len(records))
        return RecordSummary(
            out=out,
            episodes=records,
            frames=frames,
            seconds=time.perf_counter() - t0,
            resumed_at=first,
            recovered=tuple(output.actions),
            codec=opts.codec,
            formats=opts.formats,
        )
    finally:
        env.close()


def _record_episode(
    env: SimRollout, policy: PolicyAdapter, bridge: DatasetBridge, seed: int, max_steps: int, stop: _StopRequest
) -> EpisodeRecord:
    """One episode: row t = (observation t, the action the policy produced from it, what followed)."""
    stop.check()
    obs = env.reset(seed)
    policy.reset(seed)
    bridge.begin_episode(seed, env.initial_state())
    success = False
    for t in range(max_steps):
        stop.check()
        action = policy.step(obs, obs.task)
        bridge.check_action(action)  # before the producer ever sees it
        result = env.step(action)
        last = result.terminated or t == max_steps - 1
        bridge.add_step(obs, action, reward=result.reward, done=last, success=result.success)
        obs = result.observation
        if result.terminated:
            success = result.success
            break
    return bridge.end_episode(success)[0]
