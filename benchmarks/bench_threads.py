"""Encoder thread contention: W's two cameras encoded by the writer's encoder threads (`EncoderWorker`, one per
camera, both at once) with each encoder's thread budget set three ways, against the bare single-thread encode
(one encoder at a time, the two cameras interleaved from one thread: bench_writer.py's "pure").

Budgets: ``own`` (0: the encoder's own default, every core for each encoder: what the writer did before the
budget), ``budget`` (cores / cameras: the writer's default now), and ``1``. The variants run interleaved, one
round each per repetition, in one process, so a busy machine slows them alike; the medians and the ratio of
each to the bare encode (pure ÷ variant) are printed, with CPU seconds (the encoders' work, contention included).

Run (from the repository root)::

    .venv/bin/python benchmarks/bench_threads.py                       # W's frames, AV1, 3 repetitions
    .venv/bin/python benchmarks/bench_threads.py --codec h264 --repeats 5
    .venv/bin/python benchmarks/bench_threads.py --episodes 2 --frames 40  # smoke run
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path
from typing import cast

from bench_writer import run_pure
from workload import Codec, EpisodeData, Workload, make_data

from openral_data.formats.lerobot_v3.encoder import VideoSettings, encoder_threads
from openral_data.formats.lerobot_v3.video import EncoderWorker


def run_workers(data: list[EpisodeData], root: Path, wl: Workload, codec: Codec, threads: int | None) -> None:
    """The writer's encoding alone: one EncoderWorker per camera, fed step by step, one mp4 per episode."""
    settings = VideoSettings(codec=codec, threads=threads)
    budget = encoder_threads(settings, len(wl.cameras))
    workers = {cam: EncoderWorker(cam, settings, wl.fps, threads=budget) for cam in wl.cameras}
    try:
        for e, ep in enumerate(data):
            for cam, worker in workers.items():
                worker.begin(root / f"{cam}-{e:06d}.mp4", wl.height, wl.width)
            for t in range(wl.frames):
                for cam, worker in workers.items():
                    worker.put(ep.images[cam][t])
            for worker in workers.values():
                worker.finish()
    finally:
        for worker in workers.values():
            worker.close()


def _cpu() -> float:
    t = os.times()
    return t.user + t.system


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0] if __doc__ else None)
    p.add_argument("--episodes", type=int, default=10)
    p.add_argument("--frames", type=int, default=200)
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--codec", choices=["av1", "h264"], default="av1")
    args = p.parse_args(argv)
    codec = cast(Codec, args.codec)
    wl = Workload(episodes=args.episodes, frames=args.frames)
    data = make_data(wl)
    cores = len(os.sched_getaffinity(0))
    variants: dict[str, int | None] = {"own": 0, f"budget ({cores}/{len(wl.cameras)})": None, "1": 1}
    names = ["pure", *variants]
    wall: dict[str, list[float]] = {n: [] for n in names}
    cpu: dict[str, list[float]] = {n: [] for n in names}
    print(f"{cores} cores, load {os.getloadavg()}, W {wl.episodes}x{wl.frames} {wl.width}x{wl.height}, {codec}")
    with tempfile.TemporaryDirectory(prefix="openral-threads-") as tmp:
        for rep in range(args.repeats):
            for name in names:
                root = Path(tmp) / f"{rep}-{name.split()[0]}"
                root.mkdir()
                c0, t0 = _cpu(), time.perf_counter()
                if name == "pure":
                    run_pure(data, root, wl, codec)
                else:
                    run_workers(data, root, wl, codec, variants[name])
                wall[name].append(time.perf_counter() - t0)
                cpu[name].append(_cpu() - c0)
                print(f"[{rep + 1}/{args.repeats}] {name:<14} {wall[name][-1]:7.2f} s  cpu {cpu[name][-1]:6.1f} s")
    pure = statistics.median(wall["pure"])
    print(f"\n{'variant':<14} {'wall s':>8} {'frames/s':>9} {'cpu s':>7} {'pure/variant':>13}")
    for name in names:
        med = statistics.median(wall[name])
        print(
            f"{name:<14} {med:8.2f} {wl.total_frames / med:9.1f} {statistics.median(cpu[name]):7.1f} {pure / med:13.3f}"
        )
    print(f"load at end {os.getloadavg()}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
