"""`stats` at collection scale: the summaries from verified per-episode stats (fast path), from the full frame
scan (DuckDB) and from pandas, at 1 M, 10 M and 50 M frames.

For each size a LeRobot v3 dataset is generated (parquet only, the layout our writer produces: meta/info.json,
tasks, episodes metadata with `openral.success`/`openral.seed` and per-episode `stats/<feature>/{min,max,mean,std,
count}` computed from the generated frames, `.openral/digests.json` as our writer leaves it; data files rotated
every `--rows-per-file` rows, written with pyarrow in row groups of `--row-group` rows: big, yet several per
file for DuckDB's threads; `--row-group 0` writes one per episode, as our writer and lerobot's do): episodes of
600–1200 frames at 20 fps, state float32[8], action float32[7], next.reward/done/success, a few timestamp gaps.

Three contestants, each in its own fresh subprocess so that its peak RSS (VmHWM) is its own, each timed inside
its process after its imports (reading included):

* **fast**: `stats --no-health` (`run_stats`, JSON): groups (episodes, frames, duration, success rate + Wilson
  interval, length quartiles) and per-dimension count/min/max/mean/std, the dimensions pooled from the verified
  per-episode stats (the report's `sources` table must say `episode_stats`);
* **scan**: the same with `--full-scan` (DuckDB reads every frame);
* **pandas**: `pd.read_parquet` of the needed columns, `np.stack` of the list columns, the same numbers.
  It holds every frame in memory (≈ 0.5–1 GB per million frames), so it runs only up to `--pandas-max-frames`
  (default 2 M); the script prints where it was skipped and why.

`--health` adds the frame-level health checks to all three (the DuckDB contestants then scan the scalar
columns; pandas computes them as before). The script checks that every contestant found the same numbers
(counts, minima, maxima exactly; means and variances to 1e-9 of the dimension's magnitude), prints per size
the median wall/CPU time, frames per second, peak RSS and each ratio, and writes
`benchmarks/results/stats_results.json` (`--results`).

Run (from the repository root)::

    .venv/bin/python benchmarks/bench_stats.py --sizes 1000000,10000000,50000000 --repeats 3   # the table
    .venv/bin/python benchmarks/bench_stats.py --sizes 200000 --repeats 1                      # smoke run

Generated data lives under a temporary folder (`--tmp`, default the system's) and is removed at the end.
"""

from __future__ import annotations

import argparse
import json
import math
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

FPS = 20
STATE_NAMES = [f"joint{i}" for i in range(1, 8)] + ["finger"]
ACTION_NAMES = [f"joint{i}" for i in range(1, 7)] + ["gripper"]
GAP_FACTOR = 1.5
TASKS = ["pick the cube", "place the cube", "open the drawer"]
RESULTS = Path(__file__).resolve().parent / "results"


# -- dataset generation ----------------------------------------------------------------------------------------
def _episode_stats(values: np.ndarray, starts: np.ndarray, lengths: np.ndarray) -> dict[str, list[Any]]:
    """Per-episode min/max/mean/std/count of an (n, d) block holding whole episodes (two-pass std, float64),
    column by column to keep the float64 copies small."""
    d = values.shape[1]
    out: dict[str, np.ndarray] = {k: np.empty((len(starts), d)) for k in ("min", "max", "mean", "std")}
    for j in range(d):
        col = values[:, j].astype(np.float64)
        out["min"][:, j] = np.minimum.reduceat(col, starts)
        out["max"][:, j] = np.maximum.reduceat(col, starts)
        mean = np.add.reduceat(col, starts) / lengths
        out["mean"][:, j] = mean
        out["std"][:, j] = np.sqrt(np.add.reduceat((col - np.repeat(mean, lengths)) ** 2, starts) / lengths)
    lists: dict[str, list[Any]] = {k: list(v) for k, v in out.items()}
    lists["count"] = [[int(n)] for n in lengths]
    return lists


def generate(root: Path, frames: int, rows_per_file: int, row_group: int, seed: int = 0) -> dict[str, int]:
    """A dataset of about `frames` frames (whole episodes), written file by file, vectorised per file."""
    from openral_data.formats.lerobot_v3 import digests, layout
    from openral_data.formats.lerobot_v3.features import DEFAULT_FEATURES, OUTCOME_FEATURES
    from openral_data.formats.lerobot_v3.tasks_table import tasks_writer

    rng = np.random.default_rng(seed)
    lengths_all = rng.integers(600, 1201, size=frames // 600 + 2)
    ends = np.cumsum(lengths_all)
    n_eps = int(np.searchsorted(ends, frames) + 1)  # the first episodes reaching `frames`
    lengths_all = lengths_all[:n_eps]
    success = rng.random(n_eps) < 0.7
    features: dict[str, Any] = {
        "observation.state": {"dtype": "float32", "shape": [8], "names": STATE_NAMES},
        "action": {"dtype": "float32", "shape": [7], "names": ACTION_NAMES},
        **OUTCOME_FEATURES,
        **DEFAULT_FEATURES,
    }
    (root / "meta/episodes/chunk-000").mkdir(parents=True)
    (root / "data/chunk-000").mkdir(parents=True)
    (root / ".openral").mkdir()
    tasks_writer({t: i for i, t in enumerate(TASKS)})(root / layout.TASKS_PATH)
    columns: dict[str, list[Any]] = {}
    first, file_index, total = 0, 0, 0
    while first < n_eps:
        last = first
        rows = 0
        while last < n_eps and (rows == 0 or rows + lengths_all[last] <= rows_per_file):
            rows += int(lengths_all[last])
            last += 1
        lengths = lengths_all[first:last].astype(np.int64)
        starts = np.concatenate([[0], np.cumsum(lengths)[:-1]])
        episode = np.repeat(np.arange(first, last), lengths)
        t = np.arange(rows) - np.repeat(starts, lengths)
        ts = (t / FPS).astype(np.float32)
        gapped = (episode % 97 == 5) & (t >= np.repeat(lengths // 2, lengths))
        ts[gapped] += np.float32(0.25)  # a timestamp gap in every 97th episode
        state = rng.standard_normal((rows, 8), dtype=np.float32) * np.float32(0.2)
        state += np.sin(t / 50.0).astype(np.float32)[:, None]
        action = rng.standard_normal((rows, 7), dtype=np.float32) * np.float32(0.5)
        last_frame = t == np.repeat(lengths - 1, lengths)
        succ = last_frame & np.repeat(success[first:last], lengths)
        reward = succ.astype(np.float32)
        table = pa.table(
            {
                "observation.state": pa.FixedSizeListArray.from_arrays(pa.array(state.ravel()), 8),
                "action": pa.FixedSizeListArray.from_arrays(pa.array(action.ravel()), 7),
                "next.reward": pa.array(reward),
                "next.done": pa.array(last_frame),
                "next.success": pa.array(succ),
                "timestamp": pa.array(ts),
                "frame_index": pa.array(t.astype(np.int64)),
                "episode_index": pa.array(episode.astype(np.int64)),
                "index": pa.array(np.arange(total, total + rows, dtype=np.int64)),
                "task_index": pa.array((episode % len(TASKS)).astype(np.int64)),
            }
        )
        path = root / f"data/chunk-000/file-{file_index:03d}.parquet"
        if row_group:
            pq.write_table(table, path, row_group_size=row_group, compression="snappy")
        else:  # one row group per episode, as our writer and lerobot's write
            with pq.ParquetWriter(path, table.schema, compression="snappy") as w:
                for start, n in zip(starts, lengths, strict=True):
                    w.write_table(table.slice(int(start), int(n)))
        block: dict[str, list[Any]] = {
            "episode_index": list(range(first, last)),
            "tasks": [[TASKS[e % len(TASKS)]] for e in range(first, last)],
            "length": [int(n) for n in lengths],
            "data/chunk_index": [0] * (last - first),
            "data/file_index": [file_index] * (last - first),
            "dataset_from_index": [int(total + s) for s in starts],
            "dataset_to_index": [int(total + s + n) for s, n in zip(starts, lengths, strict=True)],
        }
        for key, values in (("observation.state", state), ("action", action), ("next.reward", reward[:, None])):
            for stat, col in _episode_stats(values, starts, lengths).items():
                block[f"stats/{key}/{stat}"] = col
        block["meta/episodes/chunk_index"] = [0] * (last - first)
        block["meta/episodes/file_index"] = [0] * (last - first)
        block["openral.success"] = [bool(s) for s in success[first:last]]
        block["openral.seed"] = list(range(first, last))
        for k, v in block.items():
            columns.setdefault(k, []).extend(v)
        total += rows
        first = last
        file_index += 1
    schema = {f"stats/{k}/{s}": pa.list_(pa.int64() if s == "count" else pa.float64()) for k in _STATS for s in _POOL}
    pq.write_table(
        pa.table({k: pa.array(v, schema.get(k)) for k, v in columns.items()}),
        root / "meta/episodes/chunk-000/file-000.parquet",
    )
    info = {
        "codebase_version": "v3.0",
        "fps": FPS,
        "features": features,
        "total_episodes": n_eps,
        "total_frames": total,
        "total_tasks": len(TASKS),
        "chunks_size": 1000,
        "data_files_size_in_mb": 100,
        "video_files_size_in_mb": 200,
        "data_path": layout.DATA_PATH,
        "video_path": None,
        "robot_type": "mock_arm",
        "splits": {"train": f"0:{n_eps}"},
    }
    (root / layout.INFO_PATH).write_text(json.dumps(info, indent=4))
    (root / digests.DIGESTS_PATH).write_text("{}")  # then every file hashed, as a writer's last join leaves it
    files = [p for pattern in digests.PATTERNS for p in root.glob(pattern)] + [root / r for r in digests.SINGLE]
    digests.refresh(root, [p for p in files if p.is_file()], durable=False)
    return {"episodes": n_eps, "frames": total, "data_files": file_index}


_STATS = ("observation.state", "action", "next.reward")
_POOL = ("min", "max", "mean", "std", "count")


def _cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


# -- contestants -----------------------------------------------------------------------------------------------
def _duckdb(root: Path, health: bool, full_scan: bool) -> dict[str, Any]:
    import pyarrow.dataset  # noqa: F401  (pq.read_table imports it, and pandas with it, on first use: an import)

    from openral_data.metrics.command import StatsOptions, run_stats

    t0, c0 = time.perf_counter(), _cpu()
    report = json.loads(run_stats(StatsOptions([str(root)], fmt="json", health=health, full_scan=full_scan)))
    seconds, cpu = time.perf_counter() - t0, _cpu() - c0
    g = report["groups"][0]
    return {
        "seconds": seconds,
        "cpu_seconds": cpu,
        "source": report["sources"][0]["dimensions"],
        "groups": {k: g[k] for k in _GROUP_KEYS},
        "dims": [
            [d["feature"], d["name"], d["count"], d["min"], d["max"], d["mean"], d["std"]] for d in report["dimensions"]
        ],
        "health": sorted([h["episode"], h["check"]] for h in report.get("health", [])),
    }


def contestant_fast(root: Path, health: bool) -> dict[str, Any]:
    return _duckdb(root, health, full_scan=False)


def contestant_scan(root: Path, health: bool) -> dict[str, Any]:
    return _duckdb(root, health, full_scan=True)


def contestant_pandas(root: Path, health: bool) -> dict[str, Any]:
    import pandas as pd

    from openral_data.metrics.intervals import wilson

    t0, c0 = time.perf_counter(), _cpu()
    info = json.loads((root / "meta/info.json").read_text())
    fps = info["fps"]
    # only the columns the numbers need, as DuckDB reads them (pandas/pyarrow prune columns the same way)
    eps = pd.read_parquet(
        sorted((root / "meta/episodes").glob("*/*.parquet")), columns=["episode_index", "length", "openral.success"]
    )
    wanted = ["observation.state", "action"]
    if health:
        wanted += ["next.reward", "timestamp", "index", "episode_index"]
    data = pd.read_parquet(sorted((root / "data").glob("*/*.parquet")), columns=wanted)
    lengths = eps["length"]
    k, n = int(eps["openral.success"].sum()), len(eps)
    ci = wilson(k, n)
    groups = {
        "episodes": n,
        "frames": int(lengths.sum()),
        "duration_s": float(lengths.sum() / fps),
        "successes": k,
        "success_rate": k / n,
        "ci95_low": ci.low,
        "ci95_high": ci.high,
        "len_p25": float(lengths.quantile(0.25)),
        "len_median": float(lengths.median()),
        "len_p75": float(lengths.quantile(0.75)),
    }
    dims = []
    vectors = {}
    for key, names in (("observation.state", STATE_NAMES), ("action", ACTION_NAMES)):
        values = np.stack(data[key].to_numpy()).astype(np.float64)
        vectors[key] = values
        for i, name in enumerate(names):
            col = pd.Series(values[:, i][np.isfinite(values[:, i])])
            dims.append([key, name, len(col), col.min(), col.max(), col.mean(), col.std(ddof=0)])
    health_rows: list[list[Any]] = []
    if health:
        data = data.sort_values("index")
        step = data.groupby("episode_index")["timestamp"].diff()
        nonfinite = ~np.isfinite(vectors["observation.state"].sum(axis=1)) | ~np.isfinite(vectors["action"].sum(axis=1))
        nonfinite |= ~np.isfinite(data["next.reward"].to_numpy())
        per_ep = pd.DataFrame(
            {
                "episode_index": data["episode_index"],
                "non_monotonic": step <= 0,
                "gap": step > GAP_FACTOR / fps,
                "non_finite": nonfinite,
            }
        ).groupby("episode_index")
        agg = per_ep.sum()
        counts = per_ep.size()
        meta_len = dict(zip(eps["episode_index"], eps["length"], strict=True))
        for ep, row in agg.iterrows():
            if counts[ep] != meta_len.get(ep):
                health_rows.append([int(ep), "frame_count"])
            for check in ("non_monotonic", "gap", "non_finite"):
                if row[check]:
                    health_rows.append([int(ep), _HEALTH_NAMES[check]])
    seconds, cpu = time.perf_counter() - t0, _cpu() - c0
    return {
        "seconds": seconds,
        "cpu_seconds": cpu,
        "source": "pandas",
        "groups": groups,
        "dims": dims,
        "health": sorted(health_rows),
    }


_HEALTH_NAMES = {"non_monotonic": "timestamp_non_monotonic", "gap": "timestamp_gap", "non_finite": "non_finite"}
_GROUP_KEYS = ("episodes", "frames", "duration_s", "successes", "success_rate", "ci95_low", "ci95_high")
_GROUP_KEYS += ("len_p25", "len_median", "len_p75")
CONTESTANTS = {"fast": contestant_fast, "scan": contestant_scan, "pandas": contestant_pandas}


def peak_rss_mb() -> float:
    """This process's peak resident set (VmHWM): unlike ru_maxrss, which keeps the parent's peak across fork
    and exec, it starts afresh with the program."""
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmHWM:"):
            return int(line.split()[1]) / 1024
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def _child(name: str, root: Path, health: bool) -> None:
    out = CONTESTANTS[name](root, health)
    out["peak_rss_mb"] = peak_rss_mb()
    print(json.dumps(out, default=float))


def run_child(name: str, root: Path, health: bool) -> dict[str, Any]:
    cmd = [sys.executable, __file__, "--child", name, "--root", str(root)] + (["--health"] if health else [])
    proc = subprocess.run(cmd, capture_output=True, text=True, check=False)
    if proc.returncode != 0:
        raise RuntimeError(f"{name} failed:\n{proc.stderr}")
    result: dict[str, Any] = json.loads(proc.stdout.strip().splitlines()[-1])
    return result


def same_numbers(a: dict[str, Any], b: dict[str, Any]) -> list[str]:
    """Counts, minima and maxima exactly; means to 1e-9 of the dimension's magnitude, variances to 1e-9 of its
    square (both sides sum the same float32 values in float64: they differ by rounding only)."""
    problems = []
    for key in _GROUP_KEYS:
        if not math.isclose(float(a["groups"][key]), float(b["groups"][key]), rel_tol=1e-12, abs_tol=1e-12):
            problems.append(f"groups.{key}: {a['groups'][key]} vs {b['groups'][key]}")
    for da, db in zip(a["dims"], b["dims"], strict=True):
        if da[:5] != db[:5]:
            problems.append(f"dims {da[:2]}: name/count/min/max {da[:5]} vs {db[:5]}")
            continue
        scale = max(abs(da[3]), abs(da[4]), 1e-300)
        if abs(da[5] - db[5]) > 1e-9 * scale or abs(da[6] ** 2 - db[6] ** 2) > 1e-9 * scale**2:
            problems.append(f"dims {da[:2]}: mean/std {da[5:]} vs {db[5:]}")
    if a["health"] != b["health"]:
        problems.append(f"health: {a['health'][:5]}... vs {b['health'][:5]}...")
    return problems


def bench_size(frames: int, args: argparse.Namespace, tmp: Path) -> dict[str, Any]:
    root = tmp / f"stats_{frames}"
    t0 = time.perf_counter()
    shape = generate(root, frames, args.rows_per_file, args.row_group)
    size_mb = sum(p.stat().st_size for p in root.rglob("*") if p.is_file()) / 1e6
    print(f"{frames:,} frames: generated {shape} ({size_mb:,.0f} MB) in {time.perf_counter() - t0:.1f} s", flush=True)
    names = [n for n in args.contestants.split(",") if n]
    skipped = {}
    if "pandas" in names and shape["frames"] > args.pandas_max_frames:
        names.remove("pandas")
        skipped["pandas"] = (
            f"{shape['frames']:,} frames > --pandas-max-frames {args.pandas_max_frames:,}: pandas holds every frame "
            "in memory (peak RSS at 1 M frames below; it grows linearly)"
        )
        print(f"  pandas skipped: {skipped['pandas']}", flush=True)
    runs: dict[str, list[dict[str, Any]]] = {n: [] for n in names}
    for r in range(args.repeats):
        for name in names:  # interleaved
            res = run_child(name, root, args.health)
            runs[name].append(res)
            print(
                f"  run {r + 1} {name:6s} {res['seconds']:8.2f} s wall {res['cpu_seconds']:8.2f} s CPU"
                f"  peak RSS {res['peak_rss_mb']:6.0f} MB  dimensions from {res['source']}",
                flush=True,
            )
    problems = []
    if "fast" in runs and runs["fast"][0]["source"] != "episode_stats":
        problems.append(f"fast path not taken: {runs['fast'][0]['source']}")
    ref = next(iter(runs.values()))[0]
    for name, res in runs.items():
        problems += [f"{name}: {p}" for p in same_numbers(res[0], ref)]
    med = {n: statistics.median(x["seconds"] for x in v) for n, v in runs.items()}
    cpu = {n: statistics.median(x["cpu_seconds"] for x in v) for n, v in runs.items()}
    rss = {n: max(x["peak_rss_mb"] for x in v) for n, v in runs.items()}
    ratios = {
        f"{b}/{a}": {"wall": med[b] / med[a], "cpu": cpu[b] / cpu[a], "rss": rss[b] / rss[a]}
        for a, b in (("fast", "pandas"), ("scan", "pandas"), ("fast", "scan"))
        if a in runs and b in runs
    }
    for key, r in ratios.items():
        print(f"  {key}: {r['wall']:.1f}x wall, {r['cpu']:.1f}x CPU, {r['rss']:.1f}x peak RSS", flush=True)
    for name in runs:
        print(f"  {name}: {shape['frames'] / med[name] / 1e6:.2f} M frames/s, peak RSS {rss[name]:.0f} MB", flush=True)
    if not args.keep:
        shutil.rmtree(root)
    return {
        "dataset": shape,
        "dataset_mb": size_mb,
        "median_seconds": med,
        "median_cpu_seconds": cpu,
        "peak_rss_mb": rss,
        "ratios": ratios,
        "skipped": skipped,
        "same_numbers": not problems,
        "problems": problems[:20],
        "health_issues_found": len(ref["health"]),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", default="1000000,10000000,50000000", help="frames per dataset, comma-separated")
    parser.add_argument("--contestants", default="fast,scan,pandas")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--health", action="store_true", help="add the frame-level health checks")
    parser.add_argument("--rows-per-file", type=int, default=5_000_000)
    parser.add_argument("--row-group", type=int, default=262_144, help="rows per row group; 0: one per episode")
    parser.add_argument("--pandas-max-frames", type=int, default=2_000_000)
    parser.add_argument("--tmp", type=Path, default=None, help="where to generate (default: the system's temp)")
    parser.add_argument("--keep", action="store_true", help="keep the generated datasets")
    parser.add_argument("--results", type=Path, default=RESULTS / "stats_results.json", help="results JSON")
    parser.add_argument("--child", choices=sorted(CONTESTANTS), help=argparse.SUPPRESS)
    parser.add_argument("--root", type=Path, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        _child(args.child, args.root, args.health)
        return
    sizes = [int(s) for s in args.sizes.split(",") if s]
    tmp = Path(tempfile.mkdtemp(prefix="bench_stats_", dir=args.tmp))
    try:
        results = {str(n): bench_size(n, args, tmp) for n in sizes}
    finally:
        if not args.keep:
            shutil.rmtree(tmp, ignore_errors=True)
    args.results.parent.mkdir(parents=True, exist_ok=True)
    summary = {"sizes": results, "repeats": args.repeats, "health": args.health, "date": time.strftime("%Y-%m-%d")}
    args.results.write_text(json.dumps(summary, indent=2))
    print(json.dumps({n: {k: r[k] for k in ("median_seconds", "peak_rss_mb", "ratios")} for n, r in results.items()}))
    bad = {n: r["problems"] for n, r in results.items() if not r["same_numbers"]}
    if bad:
        print("MISMATCH:\n  " + json.dumps(bad, indent=2))
        sys.exit(1)


if __name__ == "__main__":
    main()
