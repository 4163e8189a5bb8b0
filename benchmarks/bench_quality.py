"""`openral-data quality` at scale: episodes scored streaming (`metrics/quality`) against the same measures computed
naively with pandas (every column of every data file in one DataFrame, every decoded camera frame in memory).

A dataset is generated through our writer (`LeRobotV3Writer`, h264): `--frames` frames in episodes of
`--episode-frames` at 30 fps, state and action float32[7] (the last named `gripper`), two `--side`² cameras.
Every dimension is a sinusoid of its own phase; every 7th episode holds still for its first half, every 11th has a
black span on camera 0. Two contestants, each in a fresh subprocess so that its peak RSS (VmHWM) is its own, timed
inside it after its imports (reading included):

* **stream**: `quality_of(dataset, stride)` (what `openral-data quality --stride S` runs), cache written;
* **pandas**: `pd.read_parquet` of every data file (all columns), `np.stack` of state and action, the idle
  measures and timestamp gaps by `groupby`; each camera's mp4 decoded whole into a list of frames, then every
  `stride`-th frame of each episode measured for black, saturated, frozen and blurred (the same thresholds).
  It holds every decoded frame of a camera file, so it runs only up to `--naive-max-frames` (default 200 k);
  the script says where it skipped it.

Both must agree on every episode's idle fraction, idle head and tail, timestamp gaps and camera-0 black share.
Prints the wall/CPU seconds, frames per second and peak RSS of each; `--results FILE` writes them as JSON.

Run (from the repository root)::

    .venv/bin/python benchmarks/bench_quality.py --frames 1000000                  # the 1 M row (~15 min to generate)
    .venv/bin/python benchmarks/bench_quality.py --frames 100000                   # the row measured here
    .venv/bin/python benchmarks/bench_quality.py --frames 20000                    # smoke run
    .venv/bin/python benchmarks/bench_quality.py --root DS --checkouts /tmp/old . --rounds 2   # engines compared

Generated data lives under a temporary folder (`--tmp`) and is removed at the end (`--keep` keeps it).
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

FPS = 30
NAMES = ("joint1", "joint2", "joint3", "joint4", "joint5", "joint6", "gripper")
CAMERAS = ("cam0", "cam1")


# -- dataset generation ----------------------------------------------------------------------------------------
def generate(root: Path, frames: int, episode_frames: int, side: int) -> int:
    """The dataset; returns its episode count."""
    from openral_data.formats.lerobot_v3 import LeRobotV3Writer, WriterConfig
    from openral_data.formats.lerobot_v3.encoder import VideoSettings
    from openral_data.runtime.bridge import DatasetBridge
    from openral_data.types import CameraShape, DatasetSchema, Observation

    schema = DatasetSchema(
        fps=FPS,
        state_names=NAMES,
        action_names=NAMES,
        cameras={c: CameraShape(side, side) for c in CAMERAS},
        robot_type="bench",
    )
    writer = LeRobotV3Writer(root, schema, WriterConfig(video=VideoSettings(codec="h264"), durable=False))
    bridge = DatasetBridge(schema, [writer])
    rng = np.random.default_rng(0)
    textures = rng.integers(30, 226, (16, side, side, 3), dtype=np.uint8)
    black = np.zeros((side, side, 3), np.uint8)
    episodes = max(1, frames // episode_frames)
    for e in range(episodes):
        n = episode_frames
        t = np.arange(n)[:, None] / FPS
        wave = np.sin(2 * np.pi * t / 4.0 + rng.uniform(0, 2 * np.pi) + np.arange(7) * 0.9).astype(np.float32)
        if e % 7 == 3:
            wave[: n // 2] = wave[n // 2]
        bridge.begin_episode(seed=e, initial_state={})
        for i in range(n):
            images = {c: textures[(i + k) % 16] for k, c in enumerate(CAMERAS)}
            if e % 11 == 5 and n // 4 <= i < n // 2:
                images["cam0"] = black
            bridge.add_step(
                Observation(images=images, state=wave[i], task="bench"),
                wave[i],
                reward=0.0,
                done=i == n - 1,
                success=i == n - 1,
            )
        bridge.end_episode(success=True)
    bridge.close()
    return episodes


def _cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def _peak_mb() -> float:
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmHWM:"):
            return int(line.split()[1]) / 1024
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


# -- contestants -----------------------------------------------------------------------------------------------
def contestant_stream(root: Path, stride: int) -> dict[str, Any]:
    from openral_data.metrics.quality import quality_of
    from openral_data.metrics.sources import open_dataset

    t0, c0 = time.perf_counter(), _cpu()
    q = quality_of(open_dataset(root), stride, recompute=True)
    seconds, cpu = time.perf_counter() - t0, _cpu() - c0
    rows = q.table.to_pylist()
    return {
        "seconds": seconds,
        "cpu_seconds": cpu,
        "episodes": [
            [r["idle_fraction"], r["idle_head"], r["idle_tail"], r["timestamp_gaps"], r["camera_black_fraction"]]
            for r in rows
        ],
    }


def _luma(rgb: np.ndarray) -> np.ndarray:
    return rgb.astype(np.float32) @ np.array([0.299, 0.587, 0.114], np.float32)


def _faults(gray: np.ndarray, prev: np.ndarray | None) -> tuple[bool, bool, bool, bool]:
    """black, saturated, frozen, blurred of one sampled frame, by the thresholds of docs/stats.md."""
    mean = float(gray.mean())
    dark, bright = mean < 16, mean > 240
    lap = gray[:-2, 1:-1] + gray[2:, 1:-1] + gray[1:-1, :-2] + gray[1:-1, 2:] - 4 * gray[1:-1, 1:-1]
    lit = not (dark or bright)
    frozen = lit and prev is not None and float(np.abs(gray - prev).mean()) < 0.5
    return dark, bright, frozen, lit and float(lap.var()) < 10


def contestant_pandas(root: Path, stride: int) -> dict[str, Any]:  # long: the naive script, in one piece
    import av
    import pandas as pd

    t0, c0 = time.perf_counter(), _cpu()
    df = pd.concat([pd.read_parquet(f) for f in sorted((root / "data").glob("*/*.parquet"))], ignore_index=True)
    df = df.sort_values(["episode_index", "frame_index"], ignore_index=True)
    moving = np.zeros(len(df), dtype=bool)
    for key in ("observation.state", "action"):
        x = np.stack(df[key].to_numpy()).astype(np.float64)
        lo, hi = x.min(axis=0), x.max(axis=0)
        z = pd.DataFrame((x - lo) / np.where(hi > lo, hi - lo, 1.0)).loc[:, hi > lo]
        step = z.groupby(df["episode_index"]).diff().abs().max(axis=1) * FPS
        first = df.groupby("episode_index").cumcount() == 0
        step[first] = step.shift(-1)[first]  # frame 0 takes frame 1's speed
        moving |= (step >= 0.02).to_numpy()
    df["idle"] = ~moving
    dt = df.groupby("episode_index")["timestamp"].diff() * FPS
    df["gap"] = (dt > 1.5) | (dt <= 0)

    def idle_runs(idle: pd.Series) -> pd.Series:
        still = idle.to_numpy()
        go = np.flatnonzero(~still)
        head, tail = (len(still), len(still)) if not len(go) else (int(go[0]), int(len(still) - 1 - go[-1]))
        return pd.Series({"idle_fraction": still.mean(), "idle_head": head, "idle_tail": tail})

    per = df.groupby("episode_index")["idle"].apply(idle_runs).unstack()
    gaps = df.groupby("episode_index")["gap"].sum()
    eps = pd.read_parquet(sorted((root / "meta/episodes").glob("*/*.parquet")))
    black: dict[int, float] = {}  # the worst camera's share of black samples, as `camera_black_fraction`
    faults: dict[tuple[str, int], list[tuple[bool, bool, bool, bool]]] = {}
    for camera in CAMERAS:
        key = f"observation.images.{camera}"
        for (chunk, file), group in eps.groupby([f"videos/{key}/chunk_index", f"videos/{key}/file_index"]):
            path = root / f"videos/{key}/chunk-{chunk:03d}/file-{file:03d}.mp4"
            with av.open(str(path)) as container:
                frames = [f.to_ndarray(format="rgb24") for f in container.decode(video=0)]  # the whole file
            for _, row in group.iterrows():
                e, start = int(row["episode_index"]), round(row[f"videos/{key}/from_timestamp"] * FPS)
                grays = [_luma(f) for f in frames[start : start + int(row["length"]) : stride]]
                faults[camera, e] = [_faults(g, p) for g, p in zip(grays, [None, *grays[:-1]], strict=True)]
                black[e] = max(black.get(e, 0.0), float(np.mean([f[0] for f in faults[camera, e]])))
            del frames
    seconds, cpu = time.perf_counter() - t0, _cpu() - c0
    return {
        "seconds": seconds,
        "cpu_seconds": cpu,
        "episodes": [
            [float(r.idle_fraction), int(r.idle_head), int(r.idle_tail), int(gaps[e]), black[e]]
            for e, r in per.iterrows()
        ],
    }


CONTESTANTS = {"stream": contestant_stream, "pandas": contestant_pandas}


def run_one(name: str, root: Path, stride: int) -> dict[str, Any]:
    """`name` in a fresh interpreter: its result plus its peak RSS."""
    done = subprocess.run(
        [sys.executable, __file__, "--contestant", name, "--root", str(root), "--stride", str(stride)],
        capture_output=True,
        text=True,
        check=False,
    )
    if done.returncode != 0:
        raise SystemExit(f"{name} failed:\n{done.stderr}")
    return dict(json.loads(done.stdout.splitlines()[-1]))


def compare(root: Path, stride: int, checkouts: list[Path], rounds: int) -> None:
    """The stream contestant of each checkout (its own `benchmarks/bench_quality.py`, its package on PYTHONPATH)
    on the dataset at `root`, the checkouts one after the other in each of `rounds` rounds; its CPU seconds
    against the first checkout's in the same round."""
    for r in range(rounds):
        cpu: list[float] = []
        for checkout in checkouts:
            script = str(checkout / "benchmarks/bench_quality.py")
            done = subprocess.run(
                [sys.executable, script, "--contestant", "stream", "--root", str(root), "--stride", str(stride)],
                capture_output=True,
                text=True,
                check=False,
                cwd=checkout,
                env={**os.environ, "PYTHONPATH": str(checkout)},
            )
            if done.returncode != 0:
                raise SystemExit(f"{checkout} failed:\n{done.stderr}")
            out = json.loads(done.stdout.splitlines()[-1])
            cpu.append(out["cpu_seconds"])
            print(
                f"round {r + 1} {checkout!s:24s} wall {out['seconds']:7.1f} s  cpu {out['cpu_seconds']:7.1f} s  "
                f"peak RSS {out['peak_rss_mb']:5.0f} MB  {cpu[0] / cpu[-1]:4.2f}x the first's CPU  "
                f"load {os.getloadavg()[0]:.1f}",
                flush=True,
            )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--frames", type=int, default=1_000_000)
    ap.add_argument("--episode-frames", type=int, default=600)
    ap.add_argument("--side", type=int, default=64, help="camera width and height")
    ap.add_argument("--stride", type=int, default=5)
    ap.add_argument("--naive-max-frames", type=int, default=200_000)
    ap.add_argument("--tmp", type=Path, default=None)
    ap.add_argument("--keep", action="store_true")
    ap.add_argument("--results", type=Path, default=None)
    ap.add_argument("--checkouts", type=Path, nargs="+", help="compare the stream contestant of these checkouts")
    ap.add_argument("--rounds", type=int, default=1, help="with --checkouts: rounds, the checkouts interleaved")
    ap.add_argument("--contestant", choices=sorted(CONTESTANTS), help=argparse.SUPPRESS)
    ap.add_argument("--root", type=Path, help="an existing dataset (with --checkouts)")
    args = ap.parse_args()
    if args.checkouts:
        compare(args.root, args.stride, args.checkouts, args.rounds)
        return
    if args.contestant:
        out = CONTESTANTS[args.contestant](args.root, args.stride)
        print(json.dumps({**out, "peak_rss_mb": _peak_mb()}))
        return
    base = Path(tempfile.mkdtemp(prefix="bench_quality_", dir=args.tmp))
    try:
        root = base / "ds"
        t0 = time.perf_counter()
        episodes = generate(root, args.frames, args.episode_frames, args.side)
        frames = episodes * args.episode_frames
        print(
            f"generated {frames} frames, {episodes} episodes, 2 cameras {args.side}x{args.side} in "
            f"{time.perf_counter() - t0:.0f} s",
            flush=True,
        )
        results = {"frames": frames, "episodes": episodes, "side": args.side, "stride": args.stride}
        results["stream"] = run_one("stream", root, args.stride)
        if frames <= args.naive_max_frames:
            results["pandas"] = run_one("pandas", root, args.stride)
            a, b = results["stream"]["episodes"], results["pandas"]["episodes"]
            assert np.allclose(np.array(a, float), np.array(b, float), atol=1e-9), "the contestants disagree"
        else:
            print(
                f"pandas: not run above --naive-max-frames {args.naive_max_frames} (it holds every decoded frame "
                f"of a camera: ≈ {frames * args.side * args.side * 3 / 1e9:.1f} GB)"
            )
        for name in ("stream", "pandas"):
            if name in results:
                r = results[name]
                print(
                    f"{name:7s} wall {r['seconds']:7.1f} s  cpu {r['cpu_seconds']:7.1f} s  "
                    f"{frames / r['seconds']:9.0f} frames/s  peak RSS {r['peak_rss_mb']:6.0f} MB"
                )
        if args.results is not None:
            for name in ("stream", "pandas"):
                results.get(name, {}).pop("episodes", None)
            args.results.write_text(json.dumps(results, indent=2))
    finally:
        if not args.keep:
            shutil.rmtree(base, ignore_errors=True)


if __name__ == "__main__":
    main()
