"""`openral-data record` on the mock scene with workload W's cameras vs a bare PyAV encode of the same frames.

The scene (written to the scratch directory, untimed): the `mock` producer with two RGB cameras ``front`` and
``wrist`` of 256x256 at 20 fps, ``observation.state`` float32[8] (``params.state_dim``), the ``zero-mock`` rSkill
(action float32[7], all zeros: no policy cost), ``success_after`` beyond the episode so every episode runs
``max_steps`` = 200 frames; 10 episodes, seeds 0..9. Fully deterministic: frame t of episode e is a solid colour
(R = t mod 256, G = e, B = 128). Flat colour encodes far faster than bench_writer.py's rendered frames, so the
fixed per-frame and per-episode costs of recording weigh more here than on W.

Two contestants, interleaved (for each repetition, for each codec: pure, then cli):

1. **pure**: bench_writer.py's ``run_pure`` (the same function: ``libsvtav1`` g=2 crf=30 preset=12
   fast-decode=0, or ``libx264`` g=2 crf=30; one mp4 per camera per episode, one thread), fed the frames the
   mock producer gives for the same episodes. The producer is stepped in this process before anything is timed
   and its frames collected; the timed region is the encode only.
2. **cli**: a real ``python -P -m openral_data.cli -v --log-format json record --scene <yaml> --rskill zero-mock
   --n-episodes 10 --codec <codec> --out <dir>`` subprocess (what tests/support/cli.py runs). Its time is the
   **recording window** read from its JSON log records: from the ``started`` record (scene built, policy
   loaded, logged by openral_data.record.start) to the ``saved ... episode(s)`` record (logged by
   openral_data.record.runlog after the dataset is closed: mp4s joined, final metadata written). Excluded:
   the interpreter's start, every import done before ``started``, argument and scene/rSkill parsing, building
   the scene and the policy (``total_ms``), and after ``saved``: printing the summary and the interpreter's
   exit. Included: opening the output (lock, settings, the writer and its sinks), every episode (stepping the
   producer, the bridge's checks and copies, the encoder threads, the per-episode durable commits) and
   closing the dataset, plus any first-use cost (lazy imports) after ``started``. The log timestamps have
   millisecond resolution. The ``saved`` record's own ``seconds`` (the episode loop and the close, without
   opening the output) and the process wall time are reported beside it.

The child's CPU (all threads, ``/proc/<pid>/stat``) is read as its ``started`` and ``saved`` records arrive:
the window's CPU, far steadier than its wall time on a loaded machine. ``--against DIR`` runs another checkout's
``record`` (e.g. main's) beside this tree's in each repetition (each first in turn, right after the bare encode),
so two trees compare under the same load. Each child runs as ``python -P -m openral_data.cli`` with its checkout
on ``PYTHONPATH`` (checked before timing: a plain ``-m`` puts the cwd first on ``sys.path``, so before 2026-11-30
both contestants ran the tree the script was started from); ``--encoder-threads N`` passes that flag to ``record``.

Printed per codec: the medians, frames/s, CPU seconds and **pure ÷ cli** (target >= 0.9, issue #20). After each
cli run (untimed) every mp4 is demuxed and its frame count compared with the parquet rows (dropped frames), as
bench_writer.py does. Results JSON: ``--json`` (default ``benchmarks/results/cli_writer.json``).

The machine this was written for has two shared, noisy cores: compare the ratios from one run.

Run from the repository root::

    .venv/bin/python benchmarks/bench_cli_writer.py --repeats 3              # av1 and h264, median of 3
    .venv/bin/python benchmarks/bench_cli_writer.py --repeats 3 --codec av1
    .venv/bin/python benchmarks/bench_cli_writer.py --quick                  # smoke run: 2 x 20 frames, once
    .venv/bin/python benchmarks/bench_cli_writer.py --codec av1 --against /work/main   # this tree vs main's
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from dataclasses import asdict, dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import Any, cast

import numpy as np

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from bench_writer import (  # noqa: E402
    RunResult,
    check,
    machine_info,
    pure_encoder,
    run_pure,
    timed,
    video_bytes,
)

# workload sets SVT_LOG before any encoder exists; the cli subprocess inherits it
from workload import Codec, EpisodeData, ImageArray, Workload  # noqa: E402

from tests.support.scenes import mock_scene, write_yaml  # noqa: E402

RSKILL = "zero-mock"  # the mock arm's all-zero policy: action f32[7], nothing computed
CODECS: tuple[Codec, ...] = ("av1", "h264")
TARGET = 0.9
TICK = os.sysconf("SC_CLK_TCK")


# -- the scene and its frames -----------------------------------------------------------------------------
def write_scene(path: Path, wl: Workload) -> Path:
    """The mock scene with W's cameras; every episode runs `wl.frames` steps (success never comes first)."""
    data = mock_scene(
        scene_id="mock_w_bench",
        cameras=[(cam, wl.width, wl.height) for cam in wl.cameras],
        success_after=wl.frames + 1,
        max_steps=wl.frames,
        n_episodes=wl.episodes,
        fps=wl.fps,
        state_dim=wl.state_dim,
    )
    return write_yaml(path, data)


def mock_frames(scene_path: Path, wl: Workload) -> list[EpisodeData]:
    """The frames `record` gets from the mock producer for episodes 0..episodes-1 (row t = observation t)."""
    from openral_data.producers.sim.mock import MockScene
    from openral_data.schemas.scene import load_recordable_scene

    scene = load_recordable_scene(scene_path)
    env = MockScene(scene, state_dim=wl.state_dim, source=str(scene_path))
    env.start_at(0)
    action = np.zeros(wl.action_dim, np.float32)
    data: list[EpisodeData] = []
    for e in range(wl.episodes):
        images: dict[str, ImageArray] = {c: np.empty((wl.frames, wl.height, wl.width, 3), np.uint8) for c in wl.cameras}
        states = np.empty((wl.frames, wl.state_dim), np.float32)
        obs = env.reset(scene.seed + e)
        for t in range(wl.frames):
            if t:
                obs = env.step(action).observation
            for cam in wl.cameras:
                images[cam][t] = obs.images[cam]
            states[t] = obs.state
        # what the module docstring promises (and what record's dataset holds): solid (t, e, 128)
        assert (images[wl.cameras[0]][:, 0, 0] == [[t % 256, e % 256, 128] for t in range(wl.frames)]).all()
        data.append(EpisodeData(images, states, np.zeros((wl.frames, wl.action_dim), np.float32)))
    env.close()
    return data


# -- the cli contestant ------------------------------------------------------------------------------------
@dataclass
class CliRun:
    window_s: float  # `started` record -> `saved` record
    loop_s: float  # the `saved` record's own `seconds`: episode loop + close
    process_s: float  # the whole subprocess, start-up and exit included
    process_cpu_s: float  # its user + system CPU, start-up included
    window_cpu_s: float  # its CPU (all threads) from the `started` record to the `saved` record
    startup_s: float  # process start -> `started` record (imports, parsing, scene + policy)
    commit_ms: list[float] = field(default_factory=list)  # the writer's per-episode commit_ms, in order
    result: RunResult | None = None


def child_env(repo: Path = REPO) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}  # bytecode cached, as for a user
    env["PYTHONPATH"] = str(repo)
    return env


def check_tree(repo: Path) -> None:
    """Exit unless a child started as `run_cli` starts one imports openral_data from `repo` (without ``-P``
    ``python -m`` put the cwd first on sys.path, so an ``--against`` run measured the cwd's tree twice)."""
    code = "import openral_data; print(openral_data.__file__)"
    found = subprocess.run(
        [sys.executable, "-P", "-c", code], env=child_env(repo), capture_output=True, text=True, check=True
    ).stdout.strip()
    if not Path(found).resolve().is_relative_to(repo.resolve()):
        raise SystemExit(f"{repo}: its record would run openral_data from {found}")


def _stamp(record: dict[str, Any]) -> float:
    return datetime.fromisoformat(str(record["time"])).timestamp()


def _proc_cpu(pid: int) -> float:
    """A live process's user + system CPU seconds, all its threads (`/proc/<pid>/stat`, clock-tick resolution)."""
    stat = Path(f"/proc/{pid}/stat").read_text()
    fields = stat[stat.rindex(")") + 2 :].split()
    return (int(fields[11]) + int(fields[12])) / TICK


def run_cli(
    scene: Path, out: Path, episodes: int, codec: Codec, threads: int | None = None, repo: Path = REPO
) -> CliRun:
    """One `record` subprocess; its stderr is read as it comes, so the process's CPU is read at the `started` and
    `saved` records too (the recording window's CPU, robust to the machine's load)."""
    args = ["-v", "--log-format", "json", "record", "--scene", str(scene), "--rskill", RSKILL]
    args += ["--n-episodes", str(episodes), "--codec", codec, "--out", str(out)]
    args += [] if threads is None else ["--encoder-threads", str(threads)]
    cpu0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t_start = time.time()
    t0 = time.perf_counter()
    proc = subprocess.Popen(
        [sys.executable, "-P", "-m", "openral_data.cli", *args],  # -P: `repo` on PYTHONPATH, not the cwd
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
        env=child_env(repo),
    )
    assert proc.stderr is not None
    lines: list[str] = []
    marks: dict[str, float] = {}  # the process's CPU when the `started` / `saved` record arrived
    for line in proc.stderr:
        lines.append(line)
        if line.startswith("{") and ('"total_ms"' in line or '"saved"' in line):
            with contextlib.suppress(OSError, ValueError):
                marks["started" if '"total_ms"' in line else "saved"] = _proc_cpu(proc.pid)
    returncode = proc.wait()
    wall = time.perf_counter() - t0
    cpu1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    if returncode != 0:
        raise SystemExit(f"record failed (exit {returncode}): {''.join(lines)[-3000:]}")
    records = [json.loads(line) for line in lines if line.startswith("{")]
    [started] = [r for r in records if "total_ms" in r]
    [saved] = [r for r in records if "saved" in r]
    return CliRun(
        window_s=_stamp(saved) - _stamp(started),
        loop_s=float(saved["seconds"]),
        process_s=wall,
        process_cpu_s=(cpu1.ru_utime - cpu0.ru_utime) + (cpu1.ru_stime - cpu0.ru_stime),
        window_cpu_s=marks.get("saved", float("nan")) - marks.get("started", float("nan")),
        startup_s=_stamp(started) - t_start,
        commit_ms=[float(r["commit_ms"]) for r in records if "commit_ms" in r],
    )


# -- main --------------------------------------------------------------------------------------------------
def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0] if __doc__ else None)
    p.add_argument("--episodes", type=int, default=10)
    p.add_argument("--frames", type=int, default=200, help="frames (time steps) per episode")
    p.add_argument("--repeats", type=int, default=3, help="interleaved repetitions of pure, cli (median reported)")
    p.add_argument("--codec", choices=CODECS, nargs="+", default=list(CODECS))
    p.add_argument("--encoder-threads", type=int, default=None, help="record's --encoder-threads (default: not given)")
    p.add_argument(
        "--against",
        type=Path,
        default=None,
        help="another checkout (e.g. main's) whose `record` runs too, right after this tree's in each repetition",
    )
    p.add_argument("--quick", action="store_true", help="smoke run: 2 episodes x 20 frames, 1 repeat")
    p.add_argument("--json", type=Path, default=REPO / "benchmarks" / "results" / "cli_writer.json")
    p.add_argument("--tmp", type=Path, default=None, help="parent of the scratch directory (default: system temp)")
    p.add_argument("--keep", action="store_true", help="keep the written datasets")
    args = p.parse_args(argv)
    if args.quick:
        args.episodes, args.frames, args.repeats = 2, 20, 1
    for name in ("episodes", "frames", "repeats"):
        if getattr(args, name) < 1:
            p.error(f"--{name} must be >= 1")
    return args


def summarize(wl: Workload, pure: list[RunResult], cli: list[CliRun]) -> dict[str, Any]:
    pure_s = statistics.median(r.wall_s for r in pure)
    window_s = statistics.median(r.window_s for r in cli)
    later = [ms for r in cli for ms in r.commit_ms[1:]]
    return {
        "median_s": {
            "pure": pure_s,
            "cli_window": window_s,
            "cli_loop": statistics.median(r.loop_s for r in cli),
            "cli_process": statistics.median(r.process_s for r in cli),
            "cli_startup": statistics.median(r.startup_s for r in cli),
        },
        "median_cpu_s": {
            "pure": statistics.median(r.cpu_s for r in pure),
            "cli_process": statistics.median(r.process_cpu_s for r in cli),
            "cli_window": statistics.median(r.window_cpu_s for r in cli),
        },
        "frames_per_s": {"pure": wl.total_frames / pure_s, "cli": wl.total_frames / window_s},
        "commit_ms": {
            "first_episode": statistics.median(r.commit_ms[0] for r in cli) if all(r.commit_ms for r in cli) else None,
            "later_episodes": statistics.median(later) if later else None,
        },
        "pure_over_cli": pure_s / window_s,
        "dropped_frames": max((r.result.dropped or 0) if r.result else 0 for r in cli),
        "video_mb": {
            "pure": statistics.median(r.video_bytes for r in pure) / 1e6,
            "cli": statistics.median(r.result.video_bytes if r.result else 0 for r in cli) / 1e6,
        },
    }


def print_summary(wl: Workload, codec: Codec, s: dict[str, Any], repeats: int, pure: list[RunResult]) -> None:
    m, f, c = s["median_s"], s["frames_per_s"], s["commit_ms"]
    print(
        f"\n{codec}: {wl.episodes} episodes x {wl.frames} frames, 2 cameras {wl.width}x{wl.height}, median of {repeats}"
    )
    runs = " ".join(f"{r.wall_s:.2f}" for r in pure)
    print(f"  pure encode            {m['pure']:8.2f} s  {f['pure']:7.1f} frames/s  runs {runs}")
    print(f"  cli recording window   {m['cli_window']:8.2f} s  {f['cli']:7.1f} frames/s")
    print(f"  cli episode loop+close {m['cli_loop']:8.2f} s   (the `saved` record's seconds)")
    print(f"  cli start-up, excluded {m['cli_startup']:8.2f} s   (process start -> `started`)")
    print(f"  cli whole process      {m['cli_process']:8.2f} s   {s['median_cpu_s']['cli_process']:.2f} CPU s")
    cpu = s["median_cpu_s"]
    print(f"  CPU s                  pure {cpu['pure']:.2f}, cli window {cpu['cli_window']:.2f} (all threads)")
    if c["first_episode"] is not None:
        later = f"{c['later_episodes']:.0f}" if c["later_episodes"] is not None else "-"
        print(f"  commit_ms              first episode {c['first_episode']:.0f}, later episodes (median) {later}")
    print(f"  dropped frames         {s['dropped_frames']}")
    verdict = "met" if s["pure_over_cli"] >= TARGET else "not met"
    print(f"  pure / cli             {s['pure_over_cli']:.3f}  (target >= {TARGET}: {verdict})")


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    codecs = cast(list[Codec], list(dict.fromkeys(args.codec)))
    wl = Workload(episodes=args.episodes, frames=args.frames)
    scratch = Path(tempfile.mkdtemp(prefix="openral-bench-cli-", dir=args.tmp))
    os.environ["HF_HUB_OFFLINE"] = "1"  # the cli subprocess must not try the network either
    os.environ["HF_HUB_DISABLE_TELEMETRY"] = "1"
    machine = machine_info()
    print(f"scratch: {scratch}")
    print(f"machine: {machine['nproc']} cpus ({machine['cpu_model']}), load {machine['loadavg_at_start']}")
    pure: dict[Codec, list[RunResult]] = {c: [] for c in codecs}
    cli: dict[Codec, list[CliRun]] = {c: [] for c in codecs}
    against: dict[Codec, list[CliRun]] = {c: [] for c in codecs}
    trees = [("cli", REPO, cli)] + ([("against", args.against.resolve(), against)] if args.against else [])
    for _, repo, _ in trees:
        check_tree(repo)
    try:
        scene = write_scene(scratch / "mock_w.yaml", wl)
        t0 = time.perf_counter()
        data = mock_frames(scene, wl)
        mb = sum(a.nbytes for ep in data for a in ep.images.values()) / 1e6
        took = time.perf_counter() - t0
        print(
            f"collected {wl.total_frames} steps x {len(wl.cameras)} cameras ({mb:.0f} MB) from the mock in {took:.1f} s"
        )
        # untimed warm-up: encoder libraries, page cache, compiled bytecode of the cli
        warm = Workload(episodes=1, frames=4)
        for codec in codecs:
            small = [EpisodeData({c: a[:4] for c, a in data[0].images.items()}, data[0].states, data[0].actions)]
            run_pure(small, scratch / f"warmup-pure-{codec}", warm, codec)
            warm_scene = write_scene(scratch / "warm.yaml", warm)
            for name, repo, _ in trees:
                run_cli(warm_scene, scratch / f"warmup-{name}-{codec}", 1, codec, args.encoder_threads, repo)
        for rep in range(args.repeats):
            for codec in codecs:
                root = scratch / f"rep{rep}" / codec
                wall, cpu = timed("pure", data, root / "pure", wl, codec)
                p = RunResult(wall_s=wall, cpu_s=cpu, video_bytes=video_bytes(root / "pure"))
                check("pure", root / "pure", wl, p)
                pure[codec].append(p)
                for name, repo, runs in trees if rep % 2 == 0 else trees[::-1]:  # each goes first in turn
                    run = run_cli(scene, root / name, wl.episodes, codec, args.encoder_threads, repo)
                    size = video_bytes(root / name)
                    run.result = RunResult(wall_s=run.window_s, cpu_s=run.process_cpu_s, video_bytes=size)
                    check("cli", root / name, wl, run.result)
                    runs[codec].append(run)
                    print(
                        f"[{rep + 1}/{args.repeats}] {codec:<4} pure {wall:7.2f} s   "
                        f"{name:<7} window {run.window_s:6.2f} s "
                        f"(loop {run.loop_s:.2f}, process {run.process_s:.2f})   ratio {wall / run.window_s:.3f}   "
                        f"CPU s pure {cpu:.2f} window {run.window_cpu_s:.2f}   "
                        f"dropped {p.dropped}/{run.result.dropped} rows {run.result.parquet_rows}",
                        flush=True,
                    )
                if not args.keep:
                    shutil.rmtree(root, ignore_errors=True)
    finally:
        if not args.keep:
            shutil.rmtree(scratch, ignore_errors=True)

    summaries = {c: summarize(wl, pure[c], cli[c]) for c in codecs}
    for c in codecs:
        print_summary(wl, c, summaries[c], args.repeats, pure[c])
    others = {c: summarize(wl, pure[c], against[c]) for c in codecs} if args.against else {}
    for c, s in others.items():
        print(f"\n--against {args.against}:")
        print_summary(wl, c, s, args.repeats, pure[c])
    report = {
        "created": datetime.now(UTC).isoformat(timespec="seconds"),
        "workload": asdict(wl) | {"total_frames": wl.total_frames, "scene": "mock", "rskill": RSKILL},
        "repeats": args.repeats,
        "encoder_threads": args.encoder_threads,
        "target_pure_over_cli": TARGET,
        "machine": machine,
        "codecs": {
            c: {
                "pure_encoder": dict(zip(("encoder", "options"), pure_encoder(c), strict=True)),
                "pure_runs": [asdict(r) for r in pure[c]],
                "cli_runs": [asdict(r) for r in cli[c]],
                **summaries[c],
                **(
                    {"against": {"tree": str(args.against), "cli_runs": [asdict(r) for r in against[c]], **others[c]}}
                    if args.against
                    else {}
                ),
            }
            for c in codecs
        },
        "kept_datasets": str(scratch) if args.keep else None,
    }
    args.json.parent.mkdir(parents=True, exist_ok=True)
    args.json.write_text(json.dumps(report, indent=2) + "\n")
    print(f"\nresults: {args.json}")
    ok = all(s["dropped_frames"] == 0 for s in [*summaries.values(), *others.values()]) and all(
        r.result is not None and r.result.parquet_rows == wl.total_frames
        for c in codecs
        for r in [*cli[c], *against[c]]
    )
    ok = ok and all((r.dropped or 0) == 0 for c in codecs for r in pure[c])
    if not ok:
        print("FAILED: dropped frames or missing rows", file=sys.stderr)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
