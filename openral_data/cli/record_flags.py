"""The options of `openral-data record`, declared once (type, help, default) as one object (`cli/flags.py`)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Annotated

import typer

from openral_data import manifests
from openral_data.cli.encoder_flags import VCODEC_HELP, CrfFlag, GopFlag, PixFmtFlag, PresetFlag, ThreadsFlag
from openral_data.cli.jsonout import JsonFlag
from openral_data.formats.codec import Codec
from openral_data.producers.hal.teleop.declare import TakeoverRule
from openral_data.producers.hal.teleop.keys import HELP as TELEOP_KEYS
from openral_data.viz import DEFAULT_PORT

EXPERT_ONLY = ("expert", "takeover_threshold", "takeover_patience", "takeover_hold")  # `--teleop expert`'s settings
HAL_ONLY = (
    "mode", "fps", "operator", "safety", "staleness", "port", "episode_time_s", "reset_time_s", "teleop_gain",
    "realtime",
)  # fmt: skip


@dataclass(frozen=True)
class RecordFlags:
    """Every option of `record`, in its `--help` order."""

    scene: Annotated[str, typer.Option(help="scene YAML path or scene id under scenes/")] = manifests.DEFAULT_SCENE
    rskill: Annotated[
        str | None,
        typer.Option(help="rSkill id under rskills/, or a path to rskill.yaml (default: the scene's default_rskill)"),
    ] = None
    policy: Annotated[
        str | None,
        typer.Option(
            help="a lerobot checkpoint folder (or a Hub repo id in the local cache) instead of --rskill; with --hal "
            "it drives the robot (the manifest's joints)"
        ),
    ] = None
    robot: Annotated[str | None, typer.Option(help="robot id (default: the scene's robot)")] = None
    n_episodes: Annotated[int | None, typer.Option(help="episodes to record (default: the scene's)")] = None
    seed: Annotated[int | None, typer.Option(help="seed of the first episode; episode k uses seed+k")] = None
    max_steps: Annotated[int | None, typer.Option(help="step limit per episode (default: the task's)")] = None
    out: Annotated[Path | None, typer.Option(help="output folder (default: a new folder under datasets/)")] = None
    codec: Annotated[Codec, typer.Option("--vcodec", "--codec", help=VCODEC_HELP)] = "av1"
    crf: CrfFlag = None
    gop: GopFlag = None
    preset: PresetFlag = None
    pix_fmt: PixFmtFlag = None
    encoder_threads: ThreadsFlag = None
    format: Annotated[
        str, typer.Option("--format", help="lerobot, mcap or lerobot,mcap (MCAP bags go to OUT/mcap/)")
    ] = "lerobot"
    image_format: Annotated[str, typer.Option(help="MCAP camera messages: jpeg, png or raw")] = "jpeg"
    mcap_compression: Annotated[str, typer.Option(help="MCAP chunk compression: zstd, lz4 or none")] = "zstd"
    hal: Annotated[str | None, typer.Option(help="record ROBOT_ID through its HAL at a fixed rate")] = None
    mode: Annotated[str, typer.Option(help="--hal: sim (MuJoCo twin, or --scene) or real (hardware)")] = "sim"
    fps: Annotated[int, typer.Option(help="--hal: control and recording rate")] = 20
    operator: Annotated[
        str, typer.Option(help="--hal: auto, keyboard, or a script like success@40,discard@10,failure")
    ] = "auto"
    safety: Annotated[str | None, typer.Option(help="--hal: clamp or refuse (default: the manifest's)")] = None
    staleness: Annotated[float | None, typer.Option(help="--hal: camera sample age limit, s (3 periods)")] = None
    port: Annotated[str | None, typer.Option(help="--hal --mode real: serial port (default: the manifest's)")] = None
    realtime: Annotated[
        int | None,
        typer.Option(
            min=0,
            max=99,
            help="--hal: the control loop's SCHED_FIFO priority during episodes, 1-99 (0: off; default 50 with "
            "--mode real, off in sim); where the system refuses (no CAP_SYS_NICE or RLIMIT_RTPRIO) it is said once "
            "and the loop runs at normal priority",
        ),
    ] = None
    teleop: Annotated[
        str | None,
        typer.Option(
            help="a person drives: keyboard (the terminal), gamepad[=NODE] or spacemouse[=NODE] (a sim scene's "
            "end effector), or leader (hardware.teleop); keyboard, gamepad or spacemouse with --rskill or --policy: "
            "the policy drives and t, the gamepad's RB or the SpaceMouse's right button takes over and back "
            "(interventions); expert with --rskill or --policy: the scene's scripted expert takes over by its rule "
            "(--takeover-threshold/-patience/-hold, the DAgger round). "
            f"Keyboard {TELEOP_KEYS.replace('[/]', '[ and ]')}; space starts an episode, s success, f failure, "
            "d discard, r re-record, q quit"
        ),
    ] = None
    expert: Annotated[
        str | None, typer.Option(help="--teleop expert: the rSkill the expert runs (default: the scene's rSkill)")
    ] = None
    takeover_threshold: Annotated[
        float,
        typer.Option(
            min=0,
            help="--teleop expert: the expert takes over when the policy's action departs from its own by more than "
            "this share of the action's range ...",
        ),
    ] = TakeoverRule.threshold
    takeover_patience: Annotated[int, typer.Option(min=1, help="... on this many ticks in a row (--teleop expert)")] = (
        TakeoverRule.patience
    )
    takeover_hold: Annotated[
        int, typer.Option(min=1, help="--teleop expert: ticks the expert drives before it hands back")
    ] = TakeoverRule.hold
    teleop_gain: Annotated[
        float,
        typer.Option(
            help="--teleop keyboard/gamepad/spacemouse: motion scale (1: a key press moves 1 cm, full stick 2 cm/tick)"
        ),
    ] = 1.0
    episode_time_s: Annotated[
        float | None, typer.Option(help="--hal/--teleop: seconds each episode records (a verdict key ends it sooner)")
    ] = None
    reset_time_s: Annotated[
        float | None, typer.Option(help="--hal/--teleop: seconds to reset the scene between episodes (space skips)")
    ] = None
    resume: Annotated[
        bool, typer.Option("--resume", help="continue the recording in --out (its settings; --n-episodes = total)")
    ] = False
    workers: Annotated[int, typer.Option(help="record in N processes, merged by seed (openral_data/parallel)")] = 1
    executor: Annotated[str, typer.Option(help="local (processes on this machine) or ray")] = "local"
    address: Annotated[str | None, typer.Option(help="Ray cluster address (--executor ray)")] = None
    threads_per_worker: Annotated[int | None, typer.Option(help="renderer threads per worker (LP_NUM_THREADS)")] = None
    json: JsonFlag = False
    save_video: Annotated[
        bool, typer.Option("--save-video", help="write a debug mp4 per episode to OUT.debug/ (cameras + a strip)")
    ] = False
    save_video_dir: Annotated[
        Path | None, typer.Option(help="write the --save-video mp4s to this folder instead (implies --save-video)")
    ] = None
    view: Annotated[
        bool, typer.Option("--view", help="show the run live in rerun: a viewer, or a served stream when headless")
    ] = False
    view_port: Annotated[
        int, typer.Option(help="--view: port of the spawned viewer or served stream (its web page: the next one)")
    ] = DEFAULT_PORT
    view_address: Annotated[
        str | None, typer.Option(help="--view: send to this running viewer instead (rerun+http://HOST:PORT/proxy)")
    ] = None
    suite_task: Annotated[
        str | None,
        typer.Option("--task", help="a task of a suite scene, e.g. pick-place-v3 or libero_spatial/3 (list tasks)"),
    ] = None
    instruction: Annotated[str | None, typer.Option(help="the language instruction of every frame")] = None
    randomize: Annotated[
        str | None, typer.Option(help="on or off: the scene's randomize: block (default: as the YAML says)")
    ] = None
    keep: Annotated[str, typer.Option(help="all, or success: discard the episodes that do not succeed")] = "all"
    device: Annotated[
        str | None, typer.Option(help="neural policies: cpu, cuda, cuda:N, mps or auto (default: the rSkill's)")
    ] = None
