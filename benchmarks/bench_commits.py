"""Commits that stay flat: does an episode's commit cost stay the same however large the dataset grows?

Workload (the defaults): 2,000 short episodes of 10 frames at 20 fps, ``observation.state`` float32[7] and
``action`` float32[7], one 64x64 RGB camera (``--cameras 0`` for none) encoded with h264 (cheap; the commit
does not depend on the codec). The frames come from a small pre-rendered pool (a gradient with a moving
square), so producing them costs next to nothing.

The episodes go through ``DatasetBridge`` (contract checks) into ``LeRobotV3Writer`` with its default config
apart from the codec: durable per-episode commits, as ``record`` writes them, after an untimed warm-up of two
episodes into a dataset of their own (first use of the libraries). For every episode the script keeps:

* ``commit_ms``: the writer's own measure of the episode's commit (the INFO record ``episode %d committed ...``
  with ``extra={"commit_ms": ..., "flush_ms": ...}``, captured by a logging handler): the parquet/metadata
  commit alone, without the encoders' flush (``flush_ms``, kept too);
* ``end_episode_ms``: the wall time of the whole ``end_episode`` call (flush + commit + the bridge), as a
  cross-check.

It prints the median and the sum of ``commit_ms`` over the first and the last ``--window`` (100) episodes and
their ratio last / first (target <= 1.2: an episode's commit costs O(that episode)), the median per tenth of
the run (how the cost grows), the five slowest commits with their episode index (consolidations or file
rotations show up there), the time of ``close()`` and the dataset's size and file count before and after
``close()``. ``--json PATH`` writes every per-episode number. Nothing is asserted about time: the machine this
was written for has two shared, noisy cores, so read the ratio of one run, not absolute times across runs.

Finally (outside everything measured) it loads the dataset with lerobot 0.6.1's ``LeRobotDataset`` (PyAV
decoder) and checks that it has every episode and frame, and that its last frame is the last frame written
(``--no-verify`` skips this); the exit status is 1 if that check fails.

Run (from the repository root)::

    .venv/bin/python benchmarks/bench_commits.py                          # 2,000 episodes: the ratio
    .venv/bin/python benchmarks/bench_commits.py --episodes 300           # shorter
    .venv/bin/python benchmarks/bench_commits.py --quick                  # smoke run (60 episodes, window 20)
    .venv/bin/python benchmarks/bench_commits.py --cameras 0 --json benchmarks/results/commits.json
"""

from __future__ import annotations

import argparse
import json
import logging
import shutil
import statistics
import sys
import tempfile
import time
from dataclasses import asdict, dataclass
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_writer import machine_info, offline_in

from openral_data.formats.lerobot_v3 import LeRobotV3Writer, VideoSettings, WriterConfig
from openral_data.runtime.bridge import DatasetBridge
from openral_data.types import CameraShape, DatasetSchema, Observation

FPS = 20
SIZE = 64  # camera height and width
POOL = 32  # distinct pre-rendered frames, cycled
TASK = "bench commits"
TARGET = 1.2


@dataclass
class EpisodeTiming:
    episode: int
    frames_before: int  # frames already in the dataset when this episode was committed
    commit_ms: float  # the writer's commit (its log record)
    flush_ms: float  # the writer's wait for its encoders to finish the episode's videos (its log record)
    end_episode_ms: float  # wall time of the whole end_episode call


class CommitRecords(logging.Handler):
    """Collects the writer's per-episode commit records: `episode %d committed ...` with `commit_ms`."""

    def __init__(self) -> None:
        super().__init__(logging.INFO)
        self.records: dict[int, tuple[float, float]] = {}  # episode -> (commit_ms, flush_ms)

    def emit(self, record: logging.LogRecord) -> None:
        fields = record.__dict__
        if "commit_ms" in fields and "episode" in fields:
            self.records[int(fields["episode"])] = (float(fields["commit_ms"]), float(fields.get("flush_ms", 0.0)))


def frame_pool() -> npt.NDArray[np.uint8]:
    """POOL frames of SIZE x SIZE: a colour gradient with a square moving across it."""
    yy, xx = np.mgrid[0:SIZE, 0:SIZE]
    pool = np.empty((POOL, SIZE, SIZE, 3), np.uint8)
    for i in range(POOL):
        pool[i, ..., 0] = (xx * 4 + i * 8) % 256
        pool[i, ..., 1] = (yy * 4) % 256
        pool[i, ..., 2] = 128
        x0 = (i * 2) % (SIZE - 12)
        pool[i, 20:32, x0 : x0 + 12] = (250, 250, 40)
    return pool


def schema(cameras: int) -> DatasetSchema:
    return DatasetSchema(
        fps=FPS,
        state_names=tuple(f"s{i}" for i in range(7)),
        action_names=tuple(f"a{i}" for i in range(7)),
        cameras={f"cam{c}": CameraShape(SIZE, SIZE) for c in range(cameras)},
        robot_type="bench",
    )


def state(episode: int, t: int) -> npt.NDArray[np.float32]:
    out: npt.NDArray[np.float32] = np.sin(0.1 * t + 0.01 * episode + np.arange(7, dtype=np.float32)).astype(np.float32)
    return out


def record(
    root: Path, args: argparse.Namespace, handler: CommitRecords
) -> tuple[list[EpisodeTiming], float, dict[str, int]]:
    """Write the episodes; per-episode timings, the wall seconds of close() and the files before close()."""
    sch = schema(args.cameras)
    writer = LeRobotV3Writer(root, sch, WriterConfig(video=VideoSettings(codec=args.codec)))
    bridge = DatasetBridge(sch, [writer])
    pool = frame_pool()
    walls: list[float] = []
    closed = False
    try:
        for e in range(args.episodes):
            bridge.begin_episode(e, {"seed": e})
            for t in range(args.length):
                images = {cam: pool[(e + t + c) % POOL] for c, cam in enumerate(sch.cameras)}
                obs = Observation(images=images, state=state(e, t), task=TASK, time=t / FPS)
                bridge.add_step(obs, state(e, t + 1), reward=0.0, done=t == args.length - 1, success=False)
            t0 = time.perf_counter()
            bridge.end_episode(success=True)
            walls.append((time.perf_counter() - t0) * 1000)
            if args.progress and (e + 1) % args.progress == 0:
                done = handler.records.get(e, (float("nan"), 0.0))[0]
                print(f"  episode {e + 1}/{args.episodes}: commit {done:.1f} ms", flush=True)
        files_before = footprint(root)["total"]
        t0 = time.perf_counter()
        bridge.close()
        closed = True
        close_s = time.perf_counter() - t0
    finally:
        if not closed:
            bridge.close()
    missing = [e for e in range(args.episodes) if e not in handler.records]
    if missing:
        raise SystemExit(f"no commit record from the writer for episodes {missing[:10]} (of {len(missing)})")
    timings = [
        EpisodeTiming(e, e * args.length, handler.records[e][0], handler.records[e][1], walls[e])
        for e in range(args.episodes)
    ]
    return timings, close_s, files_before


def dataset_files(root: Path) -> list[Path]:
    return [p for p in root.rglob("*") if p.is_file()]


def footprint(root: Path) -> dict[str, dict[str, int]]:
    """Files and bytes per top-level folder of the dataset (and in total)."""
    out: dict[str, dict[str, int]] = {}
    for p in dataset_files(root):
        rel = p.relative_to(root)
        top = rel.parts[0] if len(rel.parts) > 1 else "."
        for key in (top, "total"):
            entry = out.setdefault(key, {"files": 0, "bytes": 0})
            entry["files"] += 1
            entry["bytes"] += p.stat().st_size
    return out


def window_stats(values: list[float]) -> dict[str, float]:
    return {"median_ms": statistics.median(values), "sum_ms": sum(values), "n": len(values)}


def summarize(timings: list[EpisodeTiming], window: int) -> dict[str, Any]:
    commits = [t.commit_ms for t in timings]
    walls = [t.end_episode_ms for t in timings]
    first, last = window_stats(commits[:window]), window_stats(commits[-window:])
    first_wall, last_wall = window_stats(walls[:window]), window_stats(walls[-window:])
    tenth = max(len(timings) // 10, 1)
    blocks = [
        {
            "episodes": [i, min(i + tenth, len(timings)) - 1],
            "median_commit_ms": statistics.median(commits[i : i + tenth]),
        }
        for i in range(0, len(timings), tenth)
    ]
    slowest = sorted(timings, key=lambda t: t.commit_ms, reverse=True)[:5]
    return {
        "window": window,
        "commit_first": first,
        "commit_last": last,
        "ratio_median": last["median_ms"] / first["median_ms"],
        "ratio_sum": last["sum_ms"] / first["sum_ms"],
        "end_episode_first": first_wall,
        "end_episode_last": last_wall,
        "end_episode_ratio_median": last_wall["median_ms"] / first_wall["median_ms"],
        "commit_total_s": sum(commits) / 1000,
        "blocks": blocks,
        "slowest": [{"episode": t.episode, "commit_ms": t.commit_ms} for t in slowest],
    }


def verify(root: Path, episodes: int, length: int) -> str | None:
    """Why lerobot's loader does not see exactly the episodes written, or None."""
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    ds = LeRobotDataset("local/x", root=root, video_backend="pyav")
    expected = episodes * length
    if len(ds) != expected or ds.num_episodes != episodes:
        return f"LeRobotDataset has {len(ds)} frames in {ds.num_episodes} episodes, expected {expected} in {episodes}"
    item = ds[len(ds) - 1]
    got = (int(item["episode_index"]), int(item["frame_index"]))
    if got != (episodes - 1, length - 1):
        return f"the last frame is (episode, frame) {got}, expected {(episodes - 1, length - 1)}"
    if not np.allclose(item["observation.state"].numpy(), state(episodes - 1, length - 1)):
        return "the last frame's observation.state differs from the one written"
    return None


def _ok(ratio: float) -> str:
    return "met" if ratio <= TARGET else "not met"


def print_report(args: argparse.Namespace, s: dict[str, Any], close_s: float, files: dict[str, Any]) -> None:
    w = s["window"]
    f, la = s["commit_first"], s["commit_last"]
    camera = f"one {SIZE}x{SIZE} camera ({args.codec})" if args.cameras else "no camera"
    print()
    print(f"workload: {args.episodes} episodes x {args.length} frames, {camera}, state/action f32[7], {FPS} fps")
    print(f"commit_ms, first {w} episodes: median {f['median_ms']:.2f} ms, sum {f['sum_ms']:.0f} ms")
    print(f"commit_ms, last {w} episodes:  median {la['median_ms']:.2f} ms, sum {la['sum_ms']:.0f} ms")
    print(f"ratio last / first (median): {s['ratio_median']:.2f}x  (target <= {TARGET}: {_ok(s['ratio_median'])})")
    print(f"ratio last / first (sum):    {s['ratio_sum']:.2f}x  (target <= {TARGET}: {_ok(s['ratio_sum'])})")
    print(
        f"end_episode wall (cross-check): median {s['end_episode_first']['median_ms']:.2f} ms first, "
        f"{s['end_episode_last']['median_ms']:.2f} ms last, ratio {s['end_episode_ratio_median']:.2f}x"
    )
    print("median commit_ms per tenth of the run: " + ", ".join(f"{b['median_commit_ms']:.1f}" for b in s["blocks"]))
    print("slowest commits: " + ", ".join(f"episode {x['episode']} {x['commit_ms']:.1f} ms" for x in s["slowest"]))
    print(f"all commits: {s['commit_total_s']:.1f} s; close(): {close_s:.2f} s")
    after = files["after_close"]
    parts = ", ".join(f"{k} {v['files']} files / {v['bytes'] / 1e6:.2f} MB" for k, v in after.items() if k != "total")
    print(
        f"dataset: {after['total']['bytes'] / 1e6:.2f} MB in {after['total']['files']} files after close() "
        f"({files['before_close']['files']} files, {files['before_close']['bytes'] / 1e6:.2f} MB before); {parts}"
    )


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0] if __doc__ else None)
    p.add_argument("--episodes", type=int, default=2000)
    p.add_argument("--length", type=int, default=10, help="frames per episode")
    p.add_argument("--cameras", type=int, choices=[0, 1], default=1, help="a 64x64 camera, or none")
    p.add_argument("--codec", choices=["h264", "av1"], default="h264")
    p.add_argument("--window", type=int, default=100, help="episodes compared at the start and at the end")
    p.add_argument("--quick", action="store_true", help="smoke run: 60 episodes, window 20")
    p.add_argument("--json", type=Path, default=None, help="write every per-episode number here")
    p.add_argument("--no-verify", action="store_true", help="skip loading the dataset with lerobot")
    p.add_argument("--progress", type=int, default=0, help="print a line every N episodes (0: none)")
    p.add_argument("--tmp", type=Path, default=None, help="parent of the scratch directory (default: system temp)")
    p.add_argument("--keep", action="store_true", help="keep the written dataset")
    args = p.parse_args(argv)
    if args.quick:
        args.episodes, args.window = 60, 20
    for name in ("episodes", "length", "window"):
        if getattr(args, name) < 1:
            p.error(f"--{name} must be >= 1")
    if args.episodes < args.window:
        p.error(f"--episodes ({args.episodes}) must be at least --window ({args.window})")
    return args


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    scratch = Path(tempfile.mkdtemp(prefix="openral-bench-commits-", dir=args.tmp))
    offline_in(scratch)

    machine = machine_info()
    print(f"scratch: {scratch}")
    print(f"machine: {machine['nproc']} cpus ({machine['cpu_model']}), load {machine['loadavg_at_start']}")
    handler = CommitRecords()
    logger = logging.getLogger("openral_data")
    level = logger.level
    logger.addHandler(handler)
    logger.setLevel(logging.INFO)
    root = scratch / "ds"
    problem: str | None = None
    try:
        # an untimed warm-up (first use of the writer's libraries), its records dropped
        record(scratch / "warmup", argparse.Namespace(**(vars(args) | {"episodes": 2, "progress": 0})), handler)
        handler.records.clear()
        t0 = time.perf_counter()
        timings, close_s, files_before = record(root, args, handler)
        wall_s = time.perf_counter() - t0
        files = {"before_close": files_before, "after_close": footprint(root)}
        summary = summarize(timings, args.window)
        print_report(args, summary, close_s, files)
        print(f"wall: {wall_s:.1f} s for {args.episodes} episodes")
        if not args.no_verify:
            problem = verify(root, args.episodes, args.length)
            print(f"lerobot 0.6.1 load: {problem or 'ok'} ({args.episodes * args.length} frames)")
    finally:
        logger.removeHandler(handler)
        logger.setLevel(level)
        if args.keep:
            print(f"dataset kept in {root}")
        else:
            shutil.rmtree(scratch, ignore_errors=True)
    if args.json is not None:
        report = {
            "created": datetime.now(UTC).isoformat(timespec="seconds"),
            "args": {k: str(v) if isinstance(v, Path) else v for k, v in vars(args).items()},
            "machine": machine,
            "wall_s": wall_s,
            "close_s": close_s,
            "files": files,
            **summary,
            "verified": None if args.no_verify else problem is None,
            "episodes": [asdict(t) for t in timings],
        }
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps(report, indent=2) + "\n")
        print(f"results: {args.json}")
    if problem:
        print(f"FAILED: {problem}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
