"""`openral-data record`: options -> `record()` (or `record --hal`, or `--workers`), progress bar, summary."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, cast

import typer

from openral_data import manifests
from openral_data.cli.encoder_flags import VCODEC_HELP, CrfFlag, GopFlag, PixFmtFlag, PresetFlag, ThreadsFlag
from openral_data.cli.given import given as given_flags
from openral_data.cli.jsonout import JsonFlag, print_json
from openral_data.cli.terminal import INTERRUPTED_RECORDING, print_line, print_rows, progress_bar
from openral_data.errors import UsageError
from openral_data.formats.codec import Codec
from openral_data.runtime.parallel.choice import is_parallel
from openral_data.viz import DEFAULT_PORT

if TYPE_CHECKING:
    from openral_data.record.options import ProgressFn, RecordOptions, RecordSummary


def record(
    ctx: typer.Context,
    scene: Annotated[str, typer.Option(help="scene YAML path or scene id under scenes/")] = manifests.DEFAULT_SCENE,
    rskill: Annotated[
        str | None,
        typer.Option(help="rSkill id under rskills/, or a path to rskill.yaml (default: the scene's default_rskill)"),
    ] = None,
    policy: Annotated[
        str | None,
        typer.Option(
            help="a lerobot checkpoint folder (or a Hub repo id in the local cache) instead of --rskill; with --hal "
            "it drives the robot (the manifest's joints)"
        ),
    ] = None,
    robot: Annotated[str | None, typer.Option(help="robot id (default: the scene's robot)")] = None,
    n_episodes: Annotated[int | None, typer.Option(help="episodes to record (default: the scene's)")] = None,
    seed: Annotated[int | None, typer.Option(help="seed of the first episode; episode k uses seed+k")] = None,
    max_steps: Annotated[int | None, typer.Option(help="step limit per episode (default: the task's)")] = None,
    out: Annotated[Path | None, typer.Option(help="output folder (default: a new folder under datasets/)")] = None,
    codec: Annotated[Codec, typer.Option("--vcodec", "--codec", help=VCODEC_HELP)] = "av1",
    crf: CrfFlag = None,
    gop: GopFlag = None,
    preset: PresetFlag = None,
    pix_fmt: PixFmtFlag = None,
    encoder_threads: ThreadsFlag = None,
    format: Annotated[
        str, typer.Option("--format", help="lerobot, mcap or lerobot,mcap (MCAP bags go to OUT/mcap/)")
    ] = "lerobot",
    image_format: Annotated[str, typer.Option(help="MCAP camera messages: jpeg, png or raw")] = "jpeg",
    mcap_compression: Annotated[str, typer.Option(help="MCAP chunk compression: zstd, lz4 or none")] = "zstd",
    hal: Annotated[str | None, typer.Option(help="record ROBOT_ID through its HAL at a fixed rate")] = None,
    mode: Annotated[str, typer.Option(help="--hal: sim (MuJoCo twin, or --scene) or real (hardware)")] = "sim",
    fps: Annotated[int, typer.Option(help="--hal: control and recording rate")] = 20,
    operator: Annotated[
        str, typer.Option(help="--hal: auto, keyboard, or a script like success@40,discard@10,failure")
    ] = "auto",
    safety: Annotated[str | None, typer.Option(help="--hal: clamp or refuse (default: the manifest's)")] = None,
    staleness: Annotated[float | None, typer.Option(help="--hal: camera sample age limit, s (3 periods)")] = None,
    port: Annotated[str | None, typer.Option(help="--hal --mode real: serial port (default: the manifest's)")] = None,
    teleop: Annotated[
        str | None,
        typer.Option(
            help="a person drives: keyboard (the terminal), gamepad[=NODE] or spacemouse[=NODE] (a sim scene's "
            "end effector), or leader (hardware.teleop); keyboard, gamepad or spacemouse with --rskill: the policy "
            "drives and t, the gamepad's RB or the SpaceMouse's right button takes over and back (interventions)"
        ),
    ] = None,
    episode_time_s: Annotated[
        float | None, typer.Option(help="--hal/--teleop: seconds each episode records (a verdict key ends it sooner)")
    ] = None,
    reset_time_s: Annotated[
        float | None, typer.Option(help="--hal/--teleop: seconds to reset the scene between episodes (space skips)")
    ] = None,
    resume: Annotated[
        bool, typer.Option("--resume", help="continue the recording in --out (its settings; --n-episodes = total)")
    ] = False,
    workers: Annotated[int, typer.Option(help="record in N processes, merged by seed (openral_data/parallel)")] = 1,
    executor: Annotated[str, typer.Option(help="local (processes on this machine) or ray")] = "local",
    address: Annotated[str | None, typer.Option(help="Ray cluster address (--executor ray)")] = None,
    threads_per_worker: Annotated[int | None, typer.Option(help="renderer threads per worker (LP_NUM_THREADS)")] = None,
    json: JsonFlag = False,
    save_video: Annotated[
        bool, typer.Option("--save-video", help="write a debug mp4 per episode to OUT.debug/ (cameras + a strip)")
    ] = False,
    save_video_dir: Annotated[
        Path | None, typer.Option(help="write the --save-video mp4s to this folder instead (implies --save-video)")
    ] = None,
    view: Annotated[
        bool, typer.Option("--view", help="show the run live in rerun: a viewer, or a served stream when headless")
    ] = False,
    view_port: Annotated[
        int, typer.Option(help="--view: port of the spawned viewer or the served stream")
    ] = DEFAULT_PORT,
    view_address: Annotated[
        str | None, typer.Option(help="--view: send to this running viewer instead (rerun+http://HOST:PORT/proxy)")
    ] = None,
    suite_task: Annotated[
        str | None,
        typer.Option("--task", help="a task of a suite scene, e.g. pick-place-v3 or libero_spatial/3 (list tasks)"),
    ] = None,
    instruction: Annotated[str | None, typer.Option(help="the language instruction of every frame")] = None,
    randomize: Annotated[
        str | None, typer.Option(help="on or off: the scene's randomize: block (default: as the YAML says)")
    ] = None,
    keep: Annotated[str, typer.Option(help="all, or success: discard the episodes that do not succeed")] = "all",
    device: Annotated[
        str | None, typer.Option(help="neural policies: cpu, cuda, cuda:N, mps or auto (default: the rSkill's)")
    ] = None,
) -> None:
    """Record episodes of SCENE driven by RSKILL or --policy into a LeRobotDataset v3 and/or ROS 2 MCAP bags."""
    # long: the typer signature declares every option with its help; the body only dispatches to the helpers below
    given = given_flags(ctx)
    from openral_data.cli.encoder_flags import video_settings

    video = video_settings(codec, crf, gop, preset, pix_fmt, encoder_threads)  # a bad combination: before anything
    if policy is not None and teleop is not None:
        raise UsageError("--policy: not with --teleop (interventions take an rSkill: --rskill R --teleop D)")
    if teleop == "leader" and hal is None:
        raise UsageError("--teleop leader: needs --hal ROBOT_ID (the robot whose manifest names the leader)")
    takeover = rskill is not None and _takes_over(teleop)  # a policy drives, the person takes over: `t`, a button
    if teleop is not None and hal is None:
        from openral_data.record.hal import teleop_scene

        hal, rskill, scene_fps, scene_steps = teleop_scene(scene, robot, rskill)
        fps = fps if "fps" in given else scene_fps
        if max_steps is None and episode_time_s is None:  # with --episode-time-s the time decides
            max_steps = scene_steps
        operator = operator if "operator" in given else ("keyboard" if teleop == "keyboard" else "auto")
        given = given | {"scene"}
    if hal is not None and (save_video or save_video_dir is not None):
        raise UsageError("--save-video/--save-video-dir: not available with --hal (a scene recording only)")
    view_given = bool(given & {"view", "view_port", "view_address"})
    if view_given and (not view or is_parallel(workers, executor)):
        raise UsageError("--view, --view-port, --view-address: need --view, and not with --workers")
    if hal is not None:
        from openral_data.cli.hal import run_hal_record
        from openral_data.formats.mcap import parse_compression, parse_image_format
        from openral_data.record.hal import HalRecordOptions, Mode
        from openral_data.record.options import DEFAULT_RSKILL
        from openral_data.runtime.sinks import parse_formats
        from openral_data.schemas.hal import SafetyMode

        if resume or workers != 1:
            raise UsageError("--resume/--workers: not available with --hal (one robot, one new dataset)")
        if (suite_task, instruction, randomize) != (None,) * 3 or keep != "all":
            raise UsageError(
                "--task/--instruction/--randomize/--keep: not available with --hal (the rSkill's own are used)"
            )
        hal_opts = HalRecordOptions(
            robot=hal,
            rskill=rskill or (None if teleop == "leader" or policy is not None else DEFAULT_RSKILL),
            mode=cast(Mode, mode),  # checked by HalRecordOptions
            fps=fps,
            scene=scene if "scene" in given else None,
            n_episodes=n_episodes if n_episodes is not None else 1,
            max_steps=max_steps,
            seed=seed if seed is not None else 0,
            out=out,
            codec=codec,
            video=video,
            formats=parse_formats(format),
            image_format=parse_image_format(image_format),
            mcap_compression=parse_compression(mcap_compression),
            operator=operator,
            safety=cast(SafetyMode | None, safety),  # checked by HalRecordOptions
            staleness=staleness,
            port=port,
            teleop=teleop,
            episode_time_s=episode_time_s,
            reset_time_s=reset_time_s,
            view=view,
            view_port=view_port,
            view_address=view_address,
            takeover=takeover,
            policy=policy,
            device=device,
        )
        run_hal_record(hal_opts, json)
        return
    hal_names = ("mode", "fps", "operator", "safety", "staleness", "port", "episode_time_s", "reset_time_s")
    hal_only = [f"--{name.replace('_', '-')}" for name in hal_names if name in given]
    if hal_only:
        raise UsageError(f"{', '.join(hal_only)}: only with --hal ROBOT_ID or --teleop (a scene runs at its own pace)")
    from openral_data.formats.mcap import parse_compression, parse_image_format
    from openral_data.record.options import Keep, RecordOptions
    from openral_data.runtime.sinks import parse_formats

    opts = RecordOptions(
        scene=scene,
        rskill=rskill,
        policy=policy,
        robot=robot,
        n_episodes=n_episodes,
        seed=seed,
        max_steps=max_steps,
        out=out,
        codec=codec,
        video=video,
        formats=parse_formats(format),
        image_format=parse_image_format(image_format),
        mcap_compression=parse_compression(mcap_compression),
        resume=resume,
        explicit=frozenset({"format": "formats", "suite_task": "task"}.get(name, name) for name in given),
        save_video=save_video,
        save_video_dir=save_video_dir,
        view=view,
        view_port=view_port,
        view_address=view_address,
        task=suite_task,
        instruction=instruction,
        device=device,
        randomize=_on_off(randomize),
        keep=cast(Keep, keep),  # checked by RecordOptions
    )
    parallel = is_parallel(workers, executor)
    if parallel:
        from openral_data.record.parallel.run import record_parallel

        summary = _with_progress(
            lambda _: record_parallel(opts, workers, executor, address, threads_per_worker), opts, n_episodes, True
        )
    else:
        from openral_data.record.sim import record as run_record

        summary = _with_progress(lambda progress: run_record(opts, progress), opts, n_episodes, False)
    if json:
        print_json("record", {**summary.to_json(), "workers": workers, "executor": executor if parallel else None})
    else:
        _print_summary(summary, resume, f"{workers} ({executor})" if parallel else None)


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
        except KeyboardInterrupt:
            bar.stop()
            _interrupted(opts.out, parallel)
            raise typer.Exit(130) from None


def _interrupted(out: Path | None, parallel: bool) -> None:
    if parallel:  # the workers' shares are merged only at the end: nothing reaches --out
        from openral_data.record.parallel.run import kept_note
        from openral_data.runtime.parallel.workdir import find_workers_dir, kept_worker_episodes

        target = find_workers_dir(out)
        kept = kept_worker_episodes(target) if target is not None else 0
        detail = kept_note(target, kept) if target is not None and kept else "nothing was written to --out"
        print_line(f"interrupted: {detail}", err=True)
    else:
        print_line(INTERRUPTED_RECORDING, err=True)


def _print_summary(summary: RecordSummary, resume: bool, workers: str | None) -> None:
    print_rows(
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


def _takes_over(teleop: str | None) -> bool:
    """`--teleop` is one a person takes over from a policy with (keyboard, gamepad[=NODE], spacemouse[=NODE])."""
    if teleop is None:
        return False
    from openral_data.producers.hal.devices import TAKEOVER_TELEOPS, device_kind

    return device_kind(teleop) in TAKEOVER_TELEOPS


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
