"""HDF5 (robomimic layout, two 256x256 image cameras) -> LeRobot v3 with `convert`, against our writer fed the
same frames, each in its own process: wall time and peak RSS.

The source (>= 1 GB by default: 10 demos x 280 steps, `obs/agentview_image` and `obs/robot0_eye_in_hand_image`
uncompressed uint8, state and action vectors) is generated into a temporary folder (``--tmp``, default /tmp).
Then, in a rotating order in every round, each contestant runs in a child process (peak RSS from `os.wait4`):

1. **writer**: `DatasetBridge` -> `LeRobotV3Writer` fed the frames read from the HDF5 with h5py one step at a
   time (what the conversion ends in, with the least reading around it),
2. **convert**: `openral-data convert SRC DST --codec CODEC` (the layout detected, its built-in mapping).

Printed: the median of the per-round ratios writer wall / convert wall (target >= 0.8x) and each contestant's
peak RSS (target for convert: <= 500 MB).

Run (from the repository root)::

    .venv/bin/python benchmarks/bench_hdf5.py                                 # >= 1 GB, h264, 2 rounds
    .venv/bin/python benchmarks/bench_hdf5.py --demos 2 --steps 50 --rounds 1  # smoke
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

SIZE = 256
CAMERAS = ("agentview_image", "robot0_eye_in_hand_image")
FPS = 20


def frame(e: int, t: int, c: int) -> np.ndarray[Any, np.dtype[np.uint8]]:
    """A moving scene: a gradient background and a bright square that travels with t (compressible like video)."""
    y, x = np.mgrid[0:SIZE, 0:SIZE]
    img = np.stack([(x + 2 * t) % 256, (y + 40 * e) % 256, np.full_like(x, 60 + 90 * c)], axis=-1).astype(np.uint8)
    p = (5 * t + 30 * c) % (SIZE - 40)
    img[p : p + 40, p : p + 40] = (250, 250, 40)
    return img


def generate(path: Path, demos: int, steps: int) -> int:
    import h5py

    with h5py.File(path, "w") as f:
        data = f.create_group("data")
        data.attrs["env_args"] = json.dumps({"env_name": "Bench", "type": 1, "env_kwargs": {"control_freq": FPS}})
        for e in range(demos):
            g = data.create_group(f"demo_{e}")
            for c, cam in enumerate(CAMERAS):
                ds = g.create_dataset(f"obs/{cam}", (steps, SIZE, SIZE, 3), dtype="uint8", chunks=(1, SIZE, SIZE, 3))
                for t in range(steps):
                    ds[t] = frame(e, t, c)
            g.create_dataset("obs/robot0_joint_pos", data=np.random.default_rng(e).normal(size=(steps, 7)))
            g.create_dataset("actions", data=np.random.default_rng(100 + e).normal(size=(steps, 7)))
            g.attrs["num_samples"] = steps
    return path.stat().st_size


def write_from_hdf5(src: Path, dst: Path, codec: str) -> None:
    """The writer contestant: the same frames, read step by step with h5py, through DatasetBridge."""
    import h5py

    from openral_data.formats.lerobot_v3 import LeRobotV3Writer, VideoSettings, WriterConfig
    from openral_data.runtime.bridge import DatasetBridge
    from openral_data.types import CameraShape, DatasetSchema, Observation

    schema = DatasetSchema(
        fps=FPS, state_names=tuple(f"s{i}" for i in range(7)), action_names=tuple(f"a{i}" for i in range(7)),
        cameras={cam.removesuffix("_image"): CameraShape(SIZE, SIZE) for cam in CAMERAS}, robot_type="bench",
    )  # fmt: skip
    bridge = DatasetBridge(schema, [LeRobotV3Writer(dst, schema, WriterConfig(video=VideoSettings(codec=codec)))])  # type: ignore[arg-type]
    try:
        with h5py.File(src, "r") as f:
            for e, name in enumerate(sorted(f["data"], key=lambda n: int(n.split("_")[1]))):
                g = f["data"][name]
                n = g["actions"].shape[0]
                bridge.begin_episode(e, {"seed": e})
                for t in range(n):
                    images = {cam.removesuffix("_image"): g[f"obs/{cam}"][t] for cam in CAMERAS}
                    state = g["obs/robot0_joint_pos"][t].astype(np.float32)
                    obs = Observation(images=images, state=state, task="Bench", time=t / FPS)
                    bridge.add_step(obs, g["actions"][t].astype(np.float32), reward=0.0, done=t == n - 1, success=False)
                bridge.end_episode(success=None)
    finally:
        bridge.close()


def run_child(args: list[str]) -> tuple[float, float]:
    """(wall seconds, peak RSS MB) of a child process."""
    t0 = time.perf_counter()
    proc = subprocess.Popen(args, stdout=subprocess.DEVNULL)
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - t0
    if status != 0:
        raise SystemExit(f"{args}: exit status {status}")
    return wall, usage.ru_maxrss / 1024


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--demos", type=int, default=10)
    p.add_argument("--steps", type=int, default=280)
    p.add_argument("--rounds", type=int, default=2)
    p.add_argument("--codec", choices=["av1", "h264"], default="h264")
    p.add_argument("--tmp", type=Path, default=Path("/tmp"))
    p.add_argument("--out", type=Path, default=Path("benchmarks/results"))
    p.add_argument("--writer-child", nargs=2, type=Path, help=argparse.SUPPRESS)
    args = p.parse_args(argv)
    if args.writer_child:
        write_from_hdf5(args.writer_child[0], args.writer_child[1], args.codec)
        return 0
    scratch = Path(tempfile.mkdtemp(prefix="openral-bench-hdf5-", dir=args.tmp))
    exe = Path(sys.executable).parent / "openral-data"
    try:
        src = scratch / "bench.hdf5"
        size = generate(src, args.demos, args.steps)
        print(f"source: {src} {size / 1e9:.2f} GB, {args.demos * args.steps} steps, 2 cameras {SIZE}x{SIZE}")
        contestants = {
            "writer": lambda dst: [
                sys.executable,
                __file__,
                "--codec",
                args.codec,
                "--writer-child",
                str(src),
                str(dst),
            ],
            "convert": lambda dst: [str(exe), "convert", str(src), str(dst), "--codec", args.codec],
        }
        walls: dict[str, list[float]] = {n: [] for n in contestants}
        rss: dict[str, list[float]] = {n: [] for n in contestants}
        names = list(contestants)
        for r in range(args.rounds):
            for name in names[r % 2 :] + names[: r % 2]:
                dst = scratch / f"r{r}-{name}"
                wall, peak = run_child(contestants[name](dst))
                walls[name].append(wall)
                rss[name].append(peak)
                shutil.rmtree(dst)
                frames = args.demos * args.steps
                print(f"[{r + 1}/{args.rounds}] {name:<8} {wall:7.1f}s {frames / wall:7.1f} frames/s  "
                      f"peak RSS {peak:6.0f} MB")  # fmt: skip
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
    ratio = [w / c for w, c in zip(walls["writer"], walls["convert"], strict=True)]
    result: dict[str, Any] = {"source_bytes": size, "codec": args.codec, "wall_s": walls, "peak_rss_mb": rss,
                              "convert_over_writer": ratio}  # fmt: skip
    print(f"convert rate / writer rate, median of rounds: {statistics.median(ratio):.2f}x "
          f"(rounds: {', '.join(f'{x:.2f}' for x in ratio)}); convert peak RSS {max(rss['convert']):.0f} MB, "
          f"writer {max(rss['writer']):.0f} MB")  # fmt: skip
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "hdf5_results.json").write_text(json.dumps(result, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
