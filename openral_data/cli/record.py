"""`openral-data record`: options -> `record()` (or `record --hal`, or `--workers`), progress bar, summary."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING, Any, cast

import typer

from openral_data.cli.flags import flags_command
from openral_data.cli.given import given as given_flags
from openral_data.cli.jsonout import print_json
from openral_data.cli.record_flags import EXPERT_ONLY, HAL_ONLY, RecordFlags
from openral_data.cli.terminal import INTERRUPTED_RECORDING, print_line, print_summary, progress_bar
from openral_data.errors import UsageError
from openral_data.runtime.parallel.choice import is_parallel

if TYPE_CHECKING:
    from openral_data.formats.lerobot_v3 import VideoSettings
    from openral_data.record.drivers.choice import DriverChoice
    from openral_data.record.options import ProgressFn, RecordOptions, RecordSummary


@flags_command(RecordFlags)
def record(ctx: typer.Context, flags: RecordFlags) -> None:
    """Record episodes of SCENE driven by RSKILL or --policy into a LeRobotDataset v3 and/or ROS 2 MCAP bags."""
    given = given_flags(ctx)
    from openral_data.cli.encoder_flags import video_settings
    from openral_data.record.drivers.choice import choose_driver
    from openral_data.record.drivers.expert import EXPERT

    f = flags
    video = video_settings(f.codec, f.crf, f.gop, f.preset, f.pix_fmt, f.encoder_threads)  # before anything
    driver = choose_driver(f.rskill, f.policy, f.teleop, hal=f.hal is not None)  # who drives: chosen once, here
    expert_only = [f"--{name.replace('_', '-')}" for name in EXPERT_ONLY if name in given]
    if expert_only and f.teleop != EXPERT:
        raise UsageError(f"{', '.join(expert_only)}: only with --teleop expert (the scripted expert's settings)")
    if driver.person and f.hal is None:
        f, given = _teleop_scene(f, given, driver)
    if f.hal is not None and (f.save_video or f.save_video_dir is not None):
        raise UsageError("--save-video/--save-video-dir: not available with --hal (a scene recording only)")
    view_given = bool(given & {"view", "view_port", "view_address"})
    if view_given and (not f.view or is_parallel(f.workers, f.executor)):
        raise UsageError("--view, --view-port, --view-address: need --view, and not with --workers")
    if f.hal is not None:
        _record_hal(f, given, video, driver)
        return
    hal_only = [f"--{name.replace('_', '-')}" for name in HAL_ONLY if name in given]
    if hal_only:
        raise UsageError(f"{', '.join(hal_only)}: only with --hal ROBOT_ID or --teleop (a scene runs at its own pace)")
    _record_scene(f, given, video)


def _teleop_scene(f: RecordFlags, given: frozenset[str], driver: DriverChoice) -> tuple[RecordFlags, frozenset[str]]:
    """`record --scene S --teleop DEVICE` is `record --hal ROBOT --scene S` with a person driving
    (`record.hal.teleop_scene`): the scene's robot, rSkill, fps and step limit unless given."""
    from openral_data.record.hal import teleop_scene

    hal, rskill, scene_fps, scene_steps = teleop_scene(f.scene, f.robot, f.rskill)
    max_steps = scene_steps if f.max_steps is None and f.episode_time_s is None else f.max_steps  # else: the time
    f = replace(
        f,
        hal=hal,
        rskill=f.rskill if f.policy is not None else rskill,  # a checkpoint drives: no rSkill (the DAgger round's)
        fps=f.fps if "fps" in given else scene_fps,
        max_steps=max_steps,
        operator=f.operator if "operator" in given else ("keyboard" if driver.terminal else "auto"),
    )
    return f, given | {"scene"}


def _record_hal(f: RecordFlags, given: frozenset[str], video: VideoSettings, driver: DriverChoice) -> None:
    """`record --hal ROBOT` (or `--teleop`): the HAL options, then the run (cli/hal.py)."""
    from openral_data.cli.hal import run_hal_record
    from openral_data.producers.hal.teleop.declare import TakeoverRule
    from openral_data.record.drivers.choice import OWN_CONTRACT, DriverKind
    from openral_data.record.hal import HalRecordOptions, Mode
    from openral_data.record.options import DEFAULT_RSKILL
    from openral_data.schemas.hal import SafetyMode

    assert f.hal is not None
    if f.workers != 1:
        raise UsageError("--workers: not available with --hal (one robot)")
    if (f.suite_task, f.instruction, f.randomize) != (None,) * 3 or f.keep != "all":
        raise UsageError(
            "--task/--instruction/--randomize/--keep: not available with --hal (the rSkill's own are used)"
        )
    hal_opts = HalRecordOptions(
        **_outputs(f, video),
        robot=f.hal,
        rskill=f.rskill or (None if driver.kind in OWN_CONTRACT or f.policy is not None else DEFAULT_RSKILL),
        mode=cast(Mode, f.mode),  # checked by HalRecordOptions
        fps=f.fps,
        scene=f.scene if "scene" in given else None,
        n_episodes=f.n_episodes if f.n_episodes is not None else 1,
        max_steps=f.max_steps,
        seed=f.seed if f.seed is not None else 0,
        operator=f.operator,
        safety=cast(SafetyMode | None, f.safety),  # checked by HalRecordOptions
        staleness=f.staleness,
        port=f.port,
        realtime=f.realtime,
        teleop=f.teleop,
        episode_time_s=f.episode_time_s,
        reset_time_s=f.reset_time_s,
        view=f.view,
        view_port=f.view_port,
        view_address=f.view_address,
        takeover=driver.kind is DriverKind.TAKEOVER,
        policy=f.policy,
        device=f.device,
        teleop_gain=f.teleop_gain,
        expert=f.expert,
        takeover_rule=TakeoverRule(f.takeover_threshold, f.takeover_patience, f.takeover_hold),
        resume=f.resume,
        explicit=frozenset({"format": "formats", "hal": "robot"}.get(name, name) for name in given),
    )
    run_hal_record(hal_opts, f.json)


def _record_scene(f: RecordFlags, given: frozenset[str], video: VideoSettings) -> None:
    """A scene recording, in this process or `--workers` processes, under the progress bar; then the summary."""
    opts = _scene_options(f, given, video)
    parallel = is_parallel(f.workers, f.executor)
    if parallel:
        from openral_data.record.parallel.run import record_parallel

        def run(_: ProgressFn) -> RecordSummary:
            return record_parallel(opts, f.workers, f.executor, f.address, f.threads_per_worker)

        summary = _with_progress(run, opts, f.n_episodes, True)
    else:
        from openral_data.record.sim import record as run_record

        summary = _with_progress(lambda progress: run_record(opts, progress), opts, f.n_episodes, False)
    if f.json:
        executor = f.executor if parallel else None
        print_json("record", {**summary.to_json(), "workers": f.workers, "executor": executor})
    else:
        _print_summary(summary, f.resume, f"{f.workers} ({f.executor})" if parallel else None)


def _outputs(f: RecordFlags, video: VideoSettings) -> dict[str, Any]:
    """Where and how a recording is written, the same for a scene's and a HAL's: --out, the codec and encoder
    settings, --format, --image-format, --mcap-compression (each checked by its parser)."""
    from openral_data.formats.mcap import parse_compression, parse_image_format
    from openral_data.runtime.sinks import parse_formats

    return {
        "out": f.out,
        "codec": f.codec,
        "video": video,
        "formats": parse_formats(f.format),
        "image_format": parse_image_format(f.image_format),
        "mcap_compression": parse_compression(f.mcap_compression),
    }


def _scene_options(f: RecordFlags, given: frozenset[str], video: VideoSettings) -> RecordOptions:
    from openral_data.record.options import Keep, RecordOptions

    return RecordOptions(
        **_outputs(f, video),
        scene=f.scene,
        rskill=f.rskill,
        policy=f.policy,
        robot=f.robot,
        n_episodes=f.n_episodes,
        seed=f.seed,
        max_steps=f.max_steps,
        resume=f.resume,
        explicit=frozenset({"format": "formats", "suite_task": "task"}.get(name, name) for name in given),
        save_video=f.save_video,
        save_video_dir=f.save_video_dir,
        view=f.view,
        view_port=f.view_port,
        view_address=f.view_address,
        task=f.suite_task,
        instruction=f.instruction,
        device=f.device,
        randomize=_on_off(f.randomize),
        keep=cast(Keep, f.keep),  # checked by RecordOptions
    )


def _with_progress(
    run: Callable[[ProgressFn], RecordSummary], opts: RecordOptions, total: int | None, parallel: bool
) -> RecordSummary:
    """`run` under the progress bar (a parallel run reports no progress); Ctrl-C says what was kept."""
    # until the first episode starts the bar says the scene is being built (robosuite's first build: ~1 min)
    with progress_bar("recording", "episodes", "{task.fields[frames]}") as bar:
        task = bar.add_task("record", total=total, frames="building the scene...")

        def progress(rec: object, frames: int, total: int) -> None:
            bar.update(task, total=total, advance=0 if rec is None else 1, frames=f"{frames} frames")

        try:
            return run(progress)
        except KeyboardInterrupt as exc:
            bar.stop()
            _interrupted(opts.out, parallel, getattr(exc, "out", None))
            raise typer.Exit(130) from None


def _interrupted(out: Path | None, parallel: bool, written: Path | None) -> None:
    """What a Ctrl-C left; `written`: the dataset folder the run had started (`RecordingInterrupted.out`)."""
    if parallel:  # the workers' shares are merged only at the end: nothing reaches --out
        from openral_data.record.parallel.run import kept_note
        from openral_data.runtime.parallel.workdir import find_workers_dir, kept_worker_episodes

        target = find_workers_dir(out)
        kept = kept_worker_episodes(target) if target is not None else 0
        detail = kept_note(target, kept) if target is not None and kept else "nothing was written to --out"
        print_line(f"interrupted: {detail}", err=True)
    else:
        print_line(INTERRUPTED_RECORDING, err=True)
        if written is not None:
            print_line(f"continue it: openral-data record --resume --out {written}", err=True)


def _print_summary(summary: RecordSummary, resume: bool, workers: str | None) -> None:
    print_summary(
        "recorded",
        [
            ("output", str(summary.out)),
            *([("resumed at", f"episode {summary.resumed_at}")] if resume else []),
            *[("recovered", line) for line in summary.recovered],
            ("episodes", _episodes_cell(len(summary.episodes), summary.resumed_at if resume else None)),
            ("success rate", f"{summary.success_rate:.1%}"),
            ("frames", str(summary.frames)),
            ("frames/s", f"{summary.fps:.1f}"),
            ("formats", ",".join(summary.formats)),
            *([("mcap bags", str(summary.out / "mcap"))] if "mcap" in summary.formats else []),
            ("codec", summary.codec),
            *([("workers", workers)] if workers is not None else []),
            *([("debug videos", str(summary.debug_videos))] if summary.debug_videos is not None else []),
        ],
    )


def _on_off(value: str | None) -> bool | None:
    if value is None:
        return None
    if value not in ("on", "off"):
        raise UsageError(f"--randomize: {value!r} is not on or off")
    return value == "on"


def _episodes_cell(added: int, resumed_at: int | None) -> str:
    """`5`, or after `--resume` every episode the dataset now holds: `5 (3 before, 2 added by this run)`."""
    if resumed_at is None:
        return str(added)
    return f"{resumed_at + added} ({resumed_at} before, {added} added by this run)"
