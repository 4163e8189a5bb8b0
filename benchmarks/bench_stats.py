"""`stats` benchmark: DuckDB over the parquet in place vs the same numbers computed with pandas.

A generated LeRobot v3 dataset (parquet only, the layout our writer produces: meta/info.json, tasks, episodes
metadata with `openral.success`/`openral.seed`, data files rotated every `--rows-per-file` rows) of
`--episodes` episodes (default 1200) with lengths drawn uniformly from [600, 1200] frames (~1.08 M frames),
state float32[8], action float32[7], next.reward/done/success, a few injected NaNs and timestamp gaps.

Two contestants, each in its own fresh subprocess so that peak RSS (ru_maxrss) is honest:

* **duckdb**: `openral_data.metrics.command.run_stats` with the JSON output: per-dataset group numbers
  (episodes, frames, duration, success rate + Wilson interval, length quartiles), per-dimension
  state/action summaries and the frame-level health checks (row counts, timestamps, NaN/Inf).
* **pandas**: `pd.read_parquet` of the data and episodes files, then the same numbers with pandas/numpy
  (`np.stack` of the list columns, `groupby`, `diff`).

Each contestant's wall and CPU time are measured inside its process after imports (the computation, reading
included);
the script checks that both computed the same numbers, prints the median over `--repeats` and the ratio,
and writes `results.json` next to the dataset.

Run (from the repository root)::

    .venv/bin/python benchmarks/bench_stats.py                 # ~1.08 M frames, 1200 episodes
    .venv/bin/python benchmarks/bench_stats.py --episodes 50   # smoke run
"""

from __future__ import annotations

import argparse
import json
import math
import resource
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


# -- dataset generation ----------------------------------------------------------------------------------------
def generate(root: Path, episodes: int, rows_per_file: int, seed: int = 0) -> dict[str, int]:
    from openral_data.formats.lerobot_v3 import layout
    from openral_data.formats.lerobot_v3.features import DEFAULT_FEATURES, OUTCOME_FEATURES
    from openral_data.formats.lerobot_v3.writer import tasks_writer

    rng = np.random.default_rng(seed)
    lengths = rng.integers(600, 1201, size=episodes)
    success = rng.random(episodes) < 0.7
    features: dict[str, Any] = {
        "observation.state": {"dtype": "float32", "shape": [8], "names": STATE_NAMES},
        "action": {"dtype": "float32", "shape": [7], "names": ACTION_NAMES},
        **OUTCOME_FEATURES,
        **DEFAULT_FEATURES,
    }
    tasks = ["pick the cube", "place the cube", "open the drawer"]
    (root / "meta/episodes/chunk-000").mkdir(parents=True)
    (root / "data/chunk-000").mkdir(parents=True)
    tasks_writer({t: i for i, t in enumerate(tasks)})(root / layout.TASKS_PATH)
    ep_rows: list[dict[str, Any]] = []
    pending: list[pa.Table] = []
    pending_rows = 0
    file_index = 0
    total = 0

    def flush() -> None:
        nonlocal pending, pending_rows, file_index
        if pending:
            path = root / f"data/chunk-000/file-{file_index:03d}.parquet"
            with pq.ParquetWriter(path, pending[0].schema, compression="snappy") as w:
                for t in pending:  # one row group per episode, as our writer and lerobot's write
                    w.write_table(t)
            file_index += 1
            pending, pending_rows = [], 0

    for e in range(episodes):
        n = int(lengths[e])
        t = np.arange(n)
        ts = (t / FPS).astype(np.float32)
        if e % 97 == 5:
            ts[n // 2 :] += 0.25  # a timestamp gap
        state = (rng.standard_normal((n, 8)) * 0.2 + np.sin(t / 50.0)[:, None]).astype(np.float32)
        action = rng.standard_normal((n, 7)).astype(np.float32) * 0.5
        if e % 113 == 7:
            action[n // 3, 2] = np.nan
        task = e % len(tasks)
        done = np.zeros(n, dtype=bool)
        done[-1] = True
        succ = np.zeros(n, dtype=bool)
        succ[-1] = bool(success[e])
        table = pa.table(
            {
                "observation.state": pa.FixedSizeListArray.from_arrays(pa.array(state.ravel()), 8),
                "action": pa.FixedSizeListArray.from_arrays(pa.array(action.ravel()), 7),
                "next.reward": pa.array(succ.astype(np.float32)),
                "next.done": pa.array(done),
                "next.success": pa.array(succ),
                "timestamp": pa.array(ts),
                "frame_index": pa.array(t.astype(np.int64)),
                "episode_index": pa.array(np.full(n, e, dtype=np.int64)),
                "index": pa.array((total + t).astype(np.int64)),
                "task_index": pa.array(np.full(n, task, dtype=np.int64)),
            }
        )
        if pending_rows + n > rows_per_file:
            flush()
        ep_rows.append(
            {
                "episode_index": e,
                "tasks": [tasks[task]],
                "length": n,
                "data/chunk_index": 0,
                "data/file_index": file_index,
                "dataset_from_index": total,
                "dataset_to_index": total + n,
                "meta/episodes/chunk_index": 0,
                "meta/episodes/file_index": 0,
                "openral.success": bool(success[e]),
                "openral.seed": e,
                "openral.initial_state": "{}",
            }
        )
        pending.append(table)
        pending_rows += n
        total += n
    flush()
    pq.write_table(pa.Table.from_pylist(ep_rows), root / "meta/episodes/chunk-000/file-000.parquet")
    info = {
        "codebase_version": "v3.0",
        "fps": FPS,
        "features": features,
        "total_episodes": episodes,
        "total_frames": total,
        "total_tasks": len(tasks),
        "chunks_size": 1000,
        "data_files_size_in_mb": 100,
        "video_files_size_in_mb": 200,
        "data_path": layout.DATA_PATH,
        "video_path": None,
        "robot_type": "mock_arm",
        "splits": {"train": f"0:{episodes}"},
    }
    (root / layout.INFO_PATH).write_text(json.dumps(info, indent=4))
    return {"episodes": episodes, "frames": total, "data_files": file_index}


def _cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


# -- contestants -----------------------------------------------------------------------------------------------
def contestant_duckdb(root: Path) -> dict[str, Any]:
    from openral_data.metrics.command import StatsOptions, run_stats

    t0, c0 = time.perf_counter(), _cpu()
    report = json.loads(run_stats(StatsOptions([str(root)], fmt="json")))
    seconds, cpu = time.perf_counter() - t0, _cpu() - c0
    g = report["groups"][0]
    return {
        "seconds": seconds,
        "cpu_seconds": cpu,
        "groups": {k: g[k] for k in _GROUP_KEYS},
        "dims": [[d["feature"], d["name"], d["min"], d["max"], d["mean"], d["std"]] for d in report["dimensions"]],
        "health": sorted([h["episode"], h["check"]] for h in report["health"]),
    }


def contestant_pandas(root: Path) -> dict[str, Any]:
    import pandas as pd

    from openral_data.metrics.intervals import wilson

    t0, c0 = time.perf_counter(), _cpu()
    info = json.loads((root / "meta/info.json").read_text())
    fps = info["fps"]
    # only the columns the numbers need, as DuckDB reads them (pandas/pyarrow prune columns the same way)
    eps = pd.read_parquet(
        sorted((root / "meta/episodes").glob("*/*.parquet")), columns=["episode_index", "length", "openral.success"]
    )
    data = pd.read_parquet(
        sorted((root / "data").glob("*/*.parquet")),
        columns=["observation.state", "action", "next.reward", "timestamp", "index", "episode_index"],
    )
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
            dims.append([key, name, col.min(), col.max(), col.mean(), col.std(ddof=0)])
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
    health = []
    meta_len = dict(zip(eps["episode_index"], eps["length"], strict=True))
    for ep, row in agg.iterrows():
        if counts[ep] != meta_len.get(ep):
            health.append([int(ep), "frame_count"])
        if row["non_monotonic"]:
            health.append([int(ep), "timestamp_non_monotonic"])
        if row["gap"]:
            health.append([int(ep), "timestamp_gap"])
        if row["non_finite"]:
            health.append([int(ep), "non_finite"])
    seconds, cpu = time.perf_counter() - t0, _cpu() - c0
    return {"seconds": seconds, "cpu_seconds": cpu, "groups": groups, "dims": dims, "health": sorted(health)}


_GROUP_KEYS = ("episodes", "frames", "duration_s", "successes", "success_rate", "ci95_low", "ci95_high")
_GROUP_KEYS += ("len_p25", "len_median", "len_p75")
CONTESTANTS = {"duckdb": contestant_duckdb, "pandas": contestant_pandas}


def _child(name: str, root: Path) -> None:
    out = CONTESTANTS[name](root)
    out["peak_rss_mb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(json.dumps(out, default=float))


def run_child(name: str, root: Path) -> dict[str, Any]:
    proc = subprocess.run(
        [sys.executable, __file__, "--child", name, "--root", str(root)],
        capture_output=True,
        text=True,
        check=False,
    )
    if proc.returncode != 0:
        raise RuntimeError(f"{name} failed:\n{proc.stderr}")
    result: dict[str, Any] = json.loads(proc.stdout.strip().splitlines()[-1])
    return result


def same_numbers(a: dict[str, Any], b: dict[str, Any]) -> list[str]:
    problems = []
    for key in _GROUP_KEYS:
        if not math.isclose(float(a["groups"][key]), float(b["groups"][key]), rel_tol=1e-9, abs_tol=1e-9):
            problems.append(f"groups.{key}: {a['groups'][key]} vs {b['groups'][key]}")
    for da, db in zip(a["dims"], b["dims"], strict=True):
        if da[:2] != db[:2]:
            problems.append(f"dims order {da[:2]} vs {db[:2]}")
        for x, y in zip(da[2:], db[2:], strict=True):
            both_nan = x is None and (y is None or (isinstance(y, float) and math.isnan(y)))
            if not both_nan and not math.isclose(float(x), float(y), rel_tol=1e-6, abs_tol=1e-6):
                problems.append(f"dims {da[:2]}: {da[2:]} vs {db[2:]}")
                break
    if a["health"] != b["health"]:
        problems.append(f"health: {a['health'][:5]}... vs {b['health'][:5]}...")
    return problems


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=1200)
    parser.add_argument("--rows-per-file", type=int, default=200_000)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--out", type=Path, default=None, help="dataset folder (default: a temporary one)")
    parser.add_argument("--child", choices=sorted(CONTESTANTS), help=argparse.SUPPRESS)
    parser.add_argument("--root", type=Path, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        _child(args.child, args.root)
        return
    with tempfile.TemporaryDirectory(prefix="bench_stats_") as tmp:
        root = args.out or Path(tmp) / "dataset"
        t0 = time.perf_counter()
        shape = generate(root, args.episodes, args.rows_per_file)
        print(f"generated {shape} in {time.perf_counter() - t0:.1f} s at {root}", flush=True)
        runs: dict[str, list[dict[str, Any]]] = {name: [] for name in CONTESTANTS}
        for r in range(args.repeats):
            for name in CONTESTANTS:
                res = run_child(name, root)
                runs[name].append(res)
                print(
                    f"  run {r + 1} {name:7s} {res['seconds']:7.2f} s wall {res['cpu_seconds']:7.2f} s CPU"
                    f"  peak RSS {res['peak_rss_mb']:7.0f} MB",
                    flush=True,
                )
        problems = same_numbers(runs["duckdb"][0], runs["pandas"][0])
        med = {n: statistics.median(x["seconds"] for x in v) for n, v in runs.items()}
        cpu = {n: statistics.median(x["cpu_seconds"] for x in v) for n, v in runs.items()}
        rss = {n: max(x["peak_rss_mb"] for x in v) for n, v in runs.items()}
        summary = {
            "dataset": shape,
            "median_seconds": med,
            "peak_rss_mb": rss,
            "median_cpu_seconds": cpu,
            "speedup_duckdb_over_pandas": med["pandas"] / med["duckdb"],
            "cpu_ratio_pandas_over_duckdb": cpu["pandas"] / cpu["duckdb"],
            "memory_ratio_pandas_over_duckdb": rss["pandas"] / rss["duckdb"],
            "same_numbers": not problems,
            "health_issues_found": len(runs["duckdb"][0]["health"]),
            "repeats": args.repeats,
        }
        print(json.dumps(summary, indent=2))
        if problems:
            print("MISMATCH:\n  " + "\n  ".join(problems[:20]))
            sys.exit(1)
        if args.out:
            (args.out / "results.json").write_text(json.dumps(summary, indent=2))


if __name__ == "__main__":
    main()
