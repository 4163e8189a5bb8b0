"""`record --workers 2` vs one process on `tabletop_push`, and the Ray executor's overhead, in one run.

Workload: the shipped `tabletop_push` scene (franka_panda, scripted-push expert, its three cameras), episodes
from seed 0. Every contestant is the real CLI in a fresh subprocess (imports, scene build and GL setup
included, as a user runs it), alternating, `--repeats` times each; ratios use the medians:

1. **one**: `openral-data record` (the plain single-process recorder; the baseline).
2. **workers2**: `record --workers 2` (two spawned processes, each its own simulator and encoder, then the
   seed-ordered merge: remux + re-indexed metadata).
3. **workers2-lp1**: the same with `--threads-per-worker 1` (llvmpipe renders with one thread per worker,
   so two workers do not fight over two cores with 2 x N render threads).
4. **ray2** (with `--ray`): `record --workers 2 --executor ray` on a local Ray instance started by the command
   (its start-up is part of the measured time: that is the overhead a user pays per command).

CPU time is the children's user+sys time (`RUSAGE_CHILDREN`), i.e. all processes and threads of the run.
An untimed `--workers 2` run of 2 episodes comes first, with bytecode caching on (see ENV).
Every run's output is checked: same number of episodes and frames as the baseline.

Run from the repository root::

    .venv/bin/python benchmarks/bench_workers.py                       # 6 episodes, 3 repeats
    .venv/bin/python benchmarks/bench_workers.py --episodes 4 --repeats 1 --ray
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import sys
import tempfile
from pathlib import Path

from timing import run_child

CLI = [sys.executable, "-m", "openral_data.cli"]
# Bytecode caching on, as on a user's machine: with PYTHONDONTWRITEBYTECODE (set in some sandboxes) every
# process recompiles pandas & co. from source, seconds of CPU per worker that no user pays.
ENV = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}


def run(name: str, extra: list[str], episodes: int, codec: str, work: Path) -> tuple[float, float, int]:
    out = work / name
    shutil.rmtree(out, ignore_errors=True)
    cmd = [*CLI, "record", "--scene", "tabletop_push", "--rskill", "scripted-push", "--n-episodes", str(episodes)]
    cmd += ["--out", str(out), "--codec", codec, *extra]
    res, wall, cpu = run_child(cmd, ENV)
    if res.returncode != 0:
        raise SystemExit(f"{name} failed: {res.stderr.strip().splitlines()[-1:]}")
    info = json.loads((out / "meta" / "info.json").read_text())
    shutil.rmtree(out, ignore_errors=True)
    return wall, cpu, int(info["total_frames"])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--episodes", type=int, default=6)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--codec", choices=["av1", "h264"], default="av1")
    ap.add_argument("--ray", action="store_true", help="also measure --executor ray")
    args = ap.parse_args()
    os.environ.setdefault("MUJOCO_GL", "egl")
    contestants: dict[str, list[str]] = {
        "one": [],
        "workers2": ["--workers", "2"],
        "workers2-lp1": ["--workers", "2", "--threads-per-worker", "1"],
    }
    if args.ray:
        contestants["ray2"] = ["--workers", "2", "--executor", "ray"]
    walls: dict[str, list[float]] = {k: [] for k in contestants}
    cpus: dict[str, list[float]] = {k: [] for k in contestants}
    frames: set[int] = set()
    with tempfile.TemporaryDirectory(prefix="bench-workers-") as tmp:
        run("warm-up", ["--workers", "2"], 2, args.codec, Path(tmp))  # untimed: fills bytecode caches
        for r in range(args.repeats):
            for name, extra in contestants.items():
                wall, cpu, n = run(name, extra, args.episodes, args.codec, Path(tmp))
                walls[name].append(wall)
                cpus[name].append(cpu)
                frames.add(n)
                print(f"repeat {r + 1}: {name:<13} wall {wall:6.1f} s  cpu {cpu:6.1f} s  frames {n}", flush=True)
    if len(frames) != 1:
        raise SystemExit(f"contestants recorded different frame counts: {sorted(frames)}")
    base = statistics.median(walls["one"])
    print(f"\n{args.episodes} episodes, {frames.pop()} frames, codec {args.codec}, {os.cpu_count()} cores, medians:")
    for name in contestants:
        w, c = statistics.median(walls[name]), statistics.median(cpus[name])
        print(f"  {name:<13} wall {w:6.1f} s  cpu {c:6.1f} s  speed-up vs one {base / w:4.2f}x")
    if args.ray:
        overhead = statistics.median(walls["ray2"]) - statistics.median(walls["workers2"])
        print(f"  Ray overhead vs local workers: {overhead:+.1f} s per command")


if __name__ == "__main__":
    main()
