"""`record`: scene + rSkill (+ robot) -> producer -> bridge -> sinks, one episode at a time."""

from __future__ import annotations

import contextlib
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from openral_data.errors import ConfigError, RecordingInterrupted, UsageError
from openral_data.formats.lerobot_v3 import WriterConfig, loadable, warm_up
from openral_data.policies.base import AnnotatingPolicy, PolicyAdapter
from openral_data.policies.checkpoint import (
    PolicyCheckpoint,
    as_rskill,
    check_fits_scene,
    load_operated,
    open_checkpoint,
)
from openral_data.policies.device import resolve_device
from openral_data.record import output, recorded
from openral_data.record.drivers.names import rskill_driver
from openral_data.record.options import (
    Keep,
    ProgressFn,
    RecordOptions,
    RecordSummary,
    check_run_numbers,
    default_out,
    rskill_ref,
)
from openral_data.record.runlog import log_episode, log_totals
from openral_data.record.session import StopRequest, ended_by, episode_loop
from openral_data.record.start import Started, start
from openral_data.runtime import available, registry, tasks
from openral_data.runtime.bridge import DatasetBridge
from openral_data.runtime.compat import check_compatibility
from openral_data.runtime.observers import check_observers, make_observers
from openral_data.runtime.schema import check_environment_state, scene_schema
from openral_data.schemas.robot import RobotManifest
from openral_data.schemas.rskill import RSkillManifest
from openral_data.schemas.scene import SimScene, load_recordable_scene
from openral_data.types import DatasetSchema, EpisodeRecord, SimRollout, Sink


def record(opts: RecordOptions, progress: ProgressFn | None = None) -> RecordSummary:
    """Record; the writer lock on `--out` is taken before anything is written there (see `output.claim`)."""
    if opts.resume:
        if opts.out is None:
            raise UsageError("--resume needs --out: the dataset folder to continue")
        held = output.claim(opts.out, "openral-data record --resume", resume=True)
        try:
            return _record(output.continue_options(opts, opts.explicit), progress, held)
        except BaseException:
            held.release()  # (a no-op when the run released it; only empty folders it made go)
            raise
    return _record(opts, progress, None)


@dataclass(frozen=True)
class _Resolved:
    """A run's inputs, resolved and checked: the scene (with its `--task`), rSkill, robot, numbers and `out`."""

    opts: RecordOptions
    scene: SimScene
    scene_src: str
    rskill: RSkillManifest
    rskill_src: str
    robot: RobotManifest
    device: str | None
    make_policy: registry.PolicyFactory
    make_scene: registry.SceneFactory
    n_episodes: int
    base_seed: int
    max_steps: int
    out: Path
    debug_videos: Path | None
    kept: dict[str, Any]  # the settings `--resume` continues with (`meta/openral.json`)
    checkpoint: PolicyCheckpoint | None = None  # `--policy`: the lerobot checkpoint driving instead of an rSkill


def _record(opts: RecordOptions, progress: ProgressFn | None, held: output.Claim | None) -> RecordSummary:
    run = _resolve(opts)
    # one writer: the lock on `out` is taken before the scene is built and before any byte goes into `out`
    if held is None:
        held = output.claim(run.out, "openral-data record", resume=False)
    opened: output.Output | None = None
    records: list[EpisodeRecord] = []
    try:
        started = _start(run)
        env, policy = started.scene, started.policy
        try:
            run.kept["device"] = getattr(policy, "device", None)  # the device a neural policy runs on; None: no network
            schema = _schema(run, env)
            opened = output.open_output(held, opts, schema, run.kept)
            bridge = _open_bridge(run, schema, opened.first_episode)
            start_at = getattr(env, "start_at", None)  # producers that number their episodes (the mock)
            if callable(start_at):
                start_at(opened.first_episode)
            t0 = time.perf_counter()
            frames, discarded = _episodes(run, env, policy, bridge, opened.first_episode, records, progress)
        finally:
            env.close()
    except KeyboardInterrupt as exc:  # the finished episodes stay in `out`, which a resume continues
        if opened is None:
            raise
        raise RecordingInterrupted(run.out) from exc
    finally:
        if opened is not None:
            output.close_output(run.out, opened, len(records))
        else:  # stopped before the settings were written: `out` is left as the claim found it
            held.release()
    seconds = time.perf_counter() - t0
    log_totals(run.out, len(records), frames, seconds)
    return RecordSummary(
        out=run.out,
        episodes=records,
        frames=frames,
        seconds=seconds,
        resumed_at=opened.first_episode,
        recovered=tuple(opened.actions),
        codec=opts.codec,
        formats=opts.formats,
        discarded=discarded,
        debug_videos=run.debug_videos,
    )


def _resolve(opts: RecordOptions) -> _Resolved:
    """Everything that can be wrong with the inputs is found here, before anything is written."""
    scene_path = registry.resolve_scene_path(opts.scene)
    scene = load_recordable_scene(scene_path)
    scene_src = str(scene_path)
    task_id = None
    if opts.task is not None:
        scene, task_id = tasks.choose_task(scene, opts.task, scene_src)
    if opts.randomize is not None:
        scene = tasks.with_randomize(scene, opts.randomize, scene_src)
    tasks.check_instruction(opts.instruction)
    device = resolve_device(opts.device) if opts.device is not None else None
    rskill, rskill_path = registry.resolve_rskill(rskill_ref(opts.rskill, scene))
    rskill_src = str(rskill_path)
    checkpoint = open_checkpoint(opts.policy) if opts.policy is not None else None
    if checkpoint is not None:  # the scene's default rSkill says what its state and action mean; the sizes: `_start`
        rskill, rskill_src = as_rskill(checkpoint, rskill), str(checkpoint.config_file)
    if opts.robot is not None and scene.scene.fixed_robot and opts.robot != scene.scene.robot:
        raise ConfigError(
            f"{scene_src}: scene.fixed_robot: this scene is defined for robot {scene.scene.robot!r} only; "
            f"--robot {opts.robot} is refused (use a free-robot scene such as scenes/sim/ to change the robot)"
        )
    available.check_scene_type(scene.scene.type, scene_src)  # a missing simulator extra: before anything loads
    robot_id = opts.robot or scene.scene.robot
    if robot_id is None:
        raise ConfigError(f"{scene_src}: scene.robot: not set; pass --robot (valid: {', '.join(registry.robot_ids())})")
    robot = registry.ROBOTS[robot_id]
    make_policy = registry.policy_factory(rskill, rskill_src)
    make_scene = registry.scene_factory(scene.scene.type, scene_src)
    n_episodes = opts.n_episodes if opts.n_episodes is not None else scene.n_episodes
    base_seed = opts.seed if opts.seed is not None else scene.seed
    max_steps = opts.max_steps if opts.max_steps is not None else scene.task.max_steps
    check_run_numbers(n_episodes, max_steps, base_seed)
    out = opts.out if opts.out is not None else default_out(scene, rskill.id)
    debug_videos = check_observers(opts, out, resume=opts.resume)
    kept = {
        "scene": str(scene_path.resolve()),
        output.DIGEST: recorded.sha256(scene_path),  # a resume that names the scene again checks it
        "rskill": str(rskill_path.resolve()) if checkpoint is None else None,
        **({"policy": str(checkpoint.path.resolve())} if checkpoint is not None else {}),
        "robot": opts.robot,
        "seed": base_seed,
        "max_steps": max_steps,
        "codec": opts.codec,
        "video": output.video_json(opts.video),
        "formats": list(opts.formats),
        "image_format": opts.image_format,
        "mcap_compression": opts.mcap_compression,
        "n_episodes": n_episodes,
        "task": task_id,
        "instruction": opts.instruction,
        "randomize": opts.randomize,
    }
    return _Resolved(
        opts, scene, scene_src, rskill, rskill_src, robot, device, make_policy, make_scene, n_episodes, base_seed,
        max_steps, out, debug_videos, kept, checkpoint,
    )  # fmt: skip


def _checks_first(opts: RecordOptions) -> bool:
    """Whether a new recording's first committed episode is checked loadable (`output.check_first_episode`)."""
    return not opts.resume and opts.check_first and "lerobot" in opts.formats


def _start(run: _Resolved) -> Started[SimRollout, PolicyAdapter]:
    """The scene built (and checked against the rSkill) while the policy loads."""
    scene, scene_src, robot, rskill = run.scene, run.scene_src, run.robot, run.rskill
    video = run.opts.video

    def load_policy() -> PolicyAdapter:
        warm_up()  # pyarrow's first-use cost, paid beside the scene's build instead of in the first commit
        if _checks_first(run.opts):
            loadable.warm_up()  # lerobot's import, paid here instead of in the first episode's check
        return load_operated(run.make_policy, rskill, device=run.device, checkpoint=run.checkpoint)

    def check(env: SimRollout) -> None:
        spec = env.spec
        if run.checkpoint is not None:  # its own contract against the scene, named on both sides
            check_fits_scene(run.checkpoint, spec, rskill, f"scene {scene_src}")
        check_compatibility(
            robot,
            rskill,
            spec,
            rskill_source=run.rskill_src,
            scene_source=scene_src,
            video=video,
            scene_type=scene.scene.type,
        )

    return start(
        lambda: run.make_scene(scene, robot, rskill, scene_src),
        check,
        load_policy,
        lambda env: env.close(),
        lambda policy: policy.close(),
    )


def _schema(run: _Resolved, env: SimRollout) -> DatasetSchema:
    check_environment_state(run.scene, run.scene_src, env.spec)
    return scene_schema(env.spec, run.scene, run.scene_src, run.robot, run.rskill, run.rskill_src)


def _open_bridge(run: _Resolved, schema: DatasetSchema, first: int) -> DatasetBridge:
    """The observers and the sinks behind one bridge; a sink that cannot open closes the observers again."""
    from openral_data.runtime.sinks import make_sinks

    opts, out = run.opts, run.out
    observers = make_observers(opts, out, schema)
    try:
        sinks: list[Sink] = make_sinks(
            out,
            schema,
            opts.formats,
            WriterConfig(video=opts.video),
            opts.image_format,
            resume=opts.resume,
            mcap_compression=opts.mcap_compression,
            first_index=opts.first_episode,
        )
    except BaseException as exc:
        with contextlib.suppress(Exception):  # closes the observers (no sink yet); the error is `exc`
            DatasetBridge(schema, [], observers=observers).close()
        explained = ended_by(exc, out, first) if isinstance(exc, OSError) else None
        if explained is None:
            raise
        raise explained from exc
    return DatasetBridge(schema, sinks, first_episode=first, observers=observers)


def _episodes(
    run: _Resolved,
    env: SimRollout,
    policy: PolicyAdapter,
    bridge: DatasetBridge,
    first: int,
    records: list[EpisodeRecord],
    progress: ProgressFn | None,
) -> tuple[int, int]:
    """Episodes `first`..n_episodes-1 into `records` (kept when a stop ends the loop); the frames recorded and the
    episodes discarded (`keep="success"`: a failed episode is not committed and takes no episode number). A new
    recording's first committed episode is checked loadable (`output.check_first_episode`)."""
    frames = discarded = 0
    with episode_loop(bridge, policy, run.out, lambda: first + len(records)) as stop:
        if progress is not None:
            progress(None, 0, max(0, run.opts.keep_target or run.n_episodes - first))
        for e in range(first, run.n_episodes):
            if run.opts.keep_target is not None and len(records) >= run.opts.keep_target:
                break  # enough kept (`generate --n`): the remaining attempts are not needed
            t_episode = time.perf_counter()
            rec = _record_episode(
                env,
                policy,
                bridge,
                run.base_seed + e,
                run.max_steps,
                stop,
                run.opts.instruction,
                run.opts.keep,
                driver=rskill_driver(run.rskill),
            )
            if rec is None:
                discarded += 1
                continue
            if first == 0 and not records and _checks_first(run.opts):  # `out` is new
                output.check_first_episode(run.out, run.opts.formats, bridge.close)
            log_episode(rec, time.perf_counter() - t_episode)
            records.append(rec)
            frames += rec.length
            if progress is not None:
                wanted = run.opts.keep_target if run.opts.keep_target is not None else run.n_episodes - first
                progress(rec, frames, max(0, wanted - (0 if run.opts.keep_target is not None else discarded)))
    return frames, discarded


def _record_episode(
    env: SimRollout,
    policy: PolicyAdapter,
    bridge: DatasetBridge,
    seed: int,
    max_steps: int,
    stop: StopRequest,
    instruction: str | None = None,
    keep: Keep = "all",
    driver: str = "policy",
) -> EpisodeRecord | None:
    """One episode: row t = (observation t, the action the policy produced from it, what followed); with an
    `instruction` (`--instruction`) that is every observation's task, for the policy and in the dataset. With
    `keep="success"` an episode that does not succeed is discarded (None). Who drove (`driver`,
    record/drivers/names.py) and what an annotating policy says of the episode go to its `openral.episode_info`."""
    stop.check()
    obs = tasks.instructed(env.reset(seed), instruction)
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
        obs = tasks.instructed(result.observation, instruction)
        if result.terminated:
            success = result.success
            break
    if keep == "success" and not success:
        bridge.discard_episode()
        return None
    info = {"operator": driver, **(policy.episode_info() if isinstance(policy, AnnotatingPolicy) else {})}
    return bridge.end_episode(success, info)[0]
