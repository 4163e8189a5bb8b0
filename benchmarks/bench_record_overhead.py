"""Recording overhead on `tabletop_push`: `record` vs stepping + rendering the same episodes without recording.

Workload: the shipped `tabletop_push` scene (franka_panda, scripted-push expert) with two cameras, `front`
and `overhead`, at 256x256 (the wrist camera is dropped), `--episodes` episodes from seed 0. Both
contestants run in one process, alternating, `--repeats` times each; the ratio uses the medians:

1. **baseline**: build the scene (compile + renderers), then for every episode `reset(seed)` and step the
   expert until success or `max_steps`; every observation renders both cameras. Nothing is written.
2. **record**: `openral_data.record.sim.record` on the same scene YAML, rSkill and seeds: the same scene
   construction, stepping and rendering, plus contract checks in the bridge, encoding (default AV1 or
   `--codec h264`) in the writer's encoder threads, parquet, stats and durable per-episode commits.

One untimed warm-up of each comes first (module imports, GL driver setup). overhead = record / baseline - 1,
for wall time and for the process's CPU time (all threads: the extra work, less sensitive to other load on a
shared machine). Both contestants step exactly the same episodes (the physics is deterministic, so the
expert takes the same actions), which the script checks by comparing frame counts.

Run from the repository root::

    .venv/bin/python benchmarks/bench_record_overhead.py                    # 5 episodes, 5 repeats, AV1
    .venv/bin/python benchmarks/bench_record_overhead.py --codec h264 --episodes 3 --repeats 1
    .venv/bin/python benchmarks/bench_record_overhead.py --breakdown --episodes 3 --repeats 3

`--breakdown` instead accounts for record's CPU per stage and per thread (`cpu_breakdown.py`: thread CPU of
wrapped methods, `/proc` for the threads Python does not run), next to the baseline's and to a bare encode
of the same frames (captured from an untimed rollout, encoded with PyAV and the writer's settings, one
mp4 per camera per episode, in the main thread; its CPU includes the codec's own threads), all in one run;
`--repeats` such triples, the medians printed.
"""

from __future__ import annotations

import argparse
import os
import shutil
import statistics
import tempfile
import time
from fractions import Fraction
from pathlib import Path

import av
import numpy as np
import pyarrow.parquet as pq
import yaml

os.environ.setdefault("MUJOCO_GL", "egl")
os.environ.setdefault("HF_HUB_OFFLINE", "1")

from cpu_breakdown import Stages, ThreadSampler
from rollouts import roll_out
from timing import Stopwatch, Timing, alternate, overhead_table, run_line

from openral_data.formats import atomic
from openral_data.formats.lerobot_v3 import VideoSettings, video
from openral_data.formats.lerobot_v3.stats import ImageStatsAccumulator
from openral_data.formats.lerobot_v3.writer import LeRobotV3Writer
from openral_data.producers.sim.mujoco.scene import TabletopScene
from openral_data.record.options import RecordOptions
from openral_data.record.sim import record
from openral_data.runtime import registry
from openral_data.runtime.bridge import DatasetBridge
from openral_data.schemas.scene import load_recordable_scene

RSKILL = "scripted-push"


def bench_scene(folder: Path, size: int) -> Path:
    data = yaml.safe_load(registry.resolve_scene_path("tabletop_push").read_text())
    data["scene"]["cameras"] = [
        {**c, "width": size, "height": size} for c in data["scene"]["cameras"] if c["name"] in ("front", "overhead")
    ]
    path = folder / "tabletop_push_2cam.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path


def baseline(scene_path: Path, episodes: int) -> Timing:
    with Stopwatch() as sw:
        cfg = load_recordable_scene(scene_path)
        rskill = registry.resolve_rskill(RSKILL)[0]
        scene = TabletopScene(cfg, registry.ROBOTS[cfg.scene.robot or "franka_panda"], rskill, "push")
        policy = registry.POLICIES[rskill.policy](rskill)
        _, frames = roll_out(scene, policy, range(episodes), cfg.task.max_steps)
    return sw.timing(frames)


def recorded(scene_path: Path, episodes: int, codec: str, out: Path) -> Timing:
    shutil.rmtree(out, ignore_errors=True)
    with Stopwatch() as sw:
        summary = record(
            RecordOptions(scene=str(scene_path), rskill=RSKILL, n_episodes=episodes, seed=0, out=out, codec=codec)  # type: ignore[arg-type]
        )
    return sw.timing(summary.frames)


Frames = list[list[dict[str, np.ndarray]]]  # episode -> step -> camera -> image


def capture(scene_path: Path, episodes: int) -> Frames:
    """The frames record writes: every observation's images until success or max_steps, per episode."""
    cfg = load_recordable_scene(scene_path)
    rskill = registry.resolve_rskill(RSKILL)[0]
    scene = TabletopScene(cfg, registry.ROBOTS[cfg.scene.robot or "franka_panda"], rskill, "push")
    policy = registry.POLICIES[rskill.policy](rskill)
    out: Frames = []
    try:
        for seed in range(episodes):
            obs, ep = scene.reset(seed), []
            policy.reset(seed)
            for _ in range(cfg.task.max_steps):
                ep.append({k: v.copy() for k, v in obs.images.items()})
                result = scene.step(policy.step(obs, obs.task))
                obs = result.observation
                if result.terminated:
                    break
            out.append(ep)
    finally:
        scene.close()
    return out


def bare_encode(frames: Frames, codec: str, folder: Path) -> float:
    """Process CPU seconds to encode `frames` with PyAV and the writer's settings, one mp4 per camera per
    episode, in this thread (the codec's own threads included)."""
    settings = VideoSettings(codec=codec)  # type: ignore[arg-type]
    c0 = time.process_time()
    for e, ep in enumerate(frames):
        for cam in ep[0]:
            with av.open(str(folder / f"bare-{e}-{cam}.mp4"), mode="w", format="mp4") as container:
                stream: av.VideoStream = container.add_stream(settings.encoder, rate=20, options=settings.options())  # type: ignore[assignment]
                h, w = ep[0][cam].shape[:2]
                stream.width, stream.height, stream.pix_fmt = w, h, settings.pix_fmt
                stream.codec_context.time_base = Fraction(1, 20)
                for i, step in enumerate(ep):
                    vf = av.VideoFrame.from_ndarray(step[cam], format="rgb24")
                    vf.pts = i
                    for packet in stream.encode(vf):
                        container.mux(packet)
                for packet in stream.encode(None):
                    container.mux(packet)
    return time.process_time() - c0


STAGES = [  # (owner, method, stage): the main thread's, then the encoder threads'
    (TabletopScene, "step", "step + render"),
    (TabletopScene, "reset", "step + render"),
    (DatasetBridge, "add_step", "bridge: contract checks, copies"),
    (LeRobotV3Writer, "add_frame", "writer.add_frame: queue hand-off, buffers"),
    (LeRobotV3Writer, "end_episode", "end_episode: encoder flush, checks"),
    (LeRobotV3Writer, "commit_episode", "commit: tables, stats, metadata"),
    (pq, "write_table", "commit: parquet writes"),
    (atomic, "fsync_file", "commit: fsyncs"),
    (atomic, "fsync_dir", "commit: fsyncs"),
    (LeRobotV3Writer, "close", "close: join videos, final metadata"),
    (video.EncoderWorker, "_encode_job", "PyAV convert + encode + mux"),
    (ImageStatsAccumulator, "add", "image histograms"),
]


def breakdown(scene_path: Path, episodes: int, codec: str, folder: Path) -> dict[str, float]:
    """One run of: baseline, record (accounted per stage and thread), bare encode of the same frames."""
    row: dict[str, float] = {}
    rskill = registry.resolve_rskill(RSKILL)[0]
    policy_cls = type(registry.POLICIES[rskill.policy](rskill))
    stages = Stages()
    for owner, attr, stage in [*STAGES[:2], (policy_cls, "step", "policy")]:
        stages.wrap(owner, attr, stage)
    t0 = time.thread_time()
    try:
        with ThreadSampler().running() as sampler:
            row["baseline CPU (all threads)"] = baseline(scene_path, episodes)[1]
    finally:
        stages.restore()
    main = time.thread_time() - t0
    row["baseline CPU (all threads)"] -= sampler.own
    for (_, stage), cpu in sorted(stages.cpu.items()):
        row[f"baseline main: {stage}"] = row.get(f"baseline main: {stage}", 0.0) + cpu
    row["baseline main: other (setup, episode loop)"] = main - sum(stages.cpu.values())
    row["baseline: llvmpipe threads"] = sampler.by_name("llvmpipe")
    row["baseline: other threads"] = row["baseline CPU (all threads)"] - main - row["baseline: llvmpipe threads"]
    stages = Stages()
    for owner, attr, stage in [*STAGES, (policy_cls, "step", "policy")]:
        stages.wrap(owner, attr, stage)
    t0 = time.thread_time()
    try:
        with ThreadSampler().running() as sampler:
            rec = recorded(scene_path, episodes, codec, folder / "ds")
    finally:
        stages.restore()
    main = time.thread_time() - t0
    row["record CPU (all threads)"] = rec[1] - sampler.own
    for (kind, stage), cpu in sorted(stages.cpu.items()):
        row[f"record {kind}: {stage}"] = row.get(f"record {kind}: {stage}", 0.0) + cpu
    row["record main: other (setup, episode loop, logging)"] = main - sum(
        cpu for (kind, _), cpu in stages.cpu.items() if kind == "main"
    )
    row["record: llvmpipe threads"] = sampler.by_name("llvmpipe")
    known = main + sum(cpu for (kind, _), cpu in stages.cpu.items() if kind != "main") + row["record: llvmpipe threads"]
    row["record: other threads (codec-internal, ...)"] = row["record CPU (all threads)"] - known
    frames = capture(scene_path, episodes)
    row["bare encode of the same frames"] = bare_encode(frames, codec, folder)
    row["frames"] = float(sum(len(ep) for ep in frames))
    return row


def print_breakdown(rows: list[dict[str, float]], episodes: int, codec: str) -> None:
    med = {k: statistics.median(r.get(k, 0.0) for r in rows) for k in rows[0]}
    base, rec, bare = (
        med["baseline CPU (all threads)"],
        med["record CPU (all threads)"],
        med["bare encode of the same frames"],
    )
    print(f"\nCPU seconds, median of {len(rows)}; {episodes} episodes, {int(med['frames'])} frames, codec {codec}:")
    print("| | CPU s | % of baseline |")
    print("|---|---|---|")
    for key, value in med.items():
        if key != "frames":
            print(f"| {key} | {value:.3f} | {100 * value / base:.1f} % |")
    extra = rec - base
    print(f"| **record - baseline (overhead)** | {extra:.3f} | **{100 * extra / base:+.1f} %** |")
    print(f"| **overhead beyond the bare encode** | {extra - bare:.3f} | **{100 * (extra - bare) / base:+.1f} %** |")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--episodes", type=int, default=5)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--size", type=int, default=256)
    parser.add_argument("--codec", choices=["av1", "h264"], default="av1")
    parser.add_argument("--breakdown", action="store_true", help="where record's CPU goes, per stage and thread")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        scene_path = bench_scene(folder, args.size)
        # warm-up, untimed: first imports of the writer's modules (pyarrow, PyAV, ...) and GL/driver setup
        baseline(scene_path, 1)
        recorded(scene_path, 1, args.codec, folder / "ds")
        if args.breakdown:
            rows = []
            for k in range(args.repeats):
                rows.append(breakdown(scene_path, args.episodes, args.codec, folder))
                print(f"run {k + 1}: " + ", ".join(f"{n} {v:.2f}" for n, v in rows[-1].items()), flush=True)
            print_breakdown(rows, args.episodes, args.codec)
            return

        def on_run(k: int, base: Timing, rec: Timing) -> None:
            fb, fr = base[2], rec[2]
            if fb != fr:
                raise SystemExit(f"baseline stepped {fb} frames but record wrote {fr}: not the same episodes")
            print(run_line(k, base, rec, "record", "frames", 1), flush=True)

        base, rec = alternate(
            args.repeats,
            lambda: baseline(scene_path, args.episodes),
            lambda: recorded(scene_path, args.episodes, args.codec, folder / "ds"),
            on_run,
        )
        fr = rec[-1][2]
        print(
            f"\ntabletop_push, 2 cameras {args.size}x{args.size}, {args.episodes} episodes, {fr} frames, "
            f"codec {args.codec}, median of {args.repeats}:"
        )
        print(overhead_table("| | baseline (step + render) | record | overhead |", "CPU (all threads)", base, rec, 1))


if __name__ == "__main__":
    main()
