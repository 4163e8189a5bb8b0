"""`openral-data generate`: generated episodes per minute, keep-rate, and whether every kept episode succeeds
again under `replay --mode actions` (benchmarks/README.md: generation).

    MUJOCO_GL=egl .venv/bin/python benchmarks/bench_generate.py --scene tabletop_pick_place --n 500 --workers 2
    MUJOCO_GL=egl .venv/bin/python benchmarks/bench_generate.py --n 40 --workers 1 2    # the rate, 1 vs 2 processes

Records `--sources` scripted demonstrations on the source scene first (the scene's default expert), then runs
`generate` once per `--workers` value (seeds 1000...), then replays each output. Results JSON goes to
benchmarks/results/generate-<scene>.json.
"""

from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

CLI = [sys.executable, "-m", "openral_data.cli"]


def run(*args: str) -> dict[str, object]:
    done = subprocess.run([*CLI, *args, "--json"], capture_output=True, text=True, check=False)
    if done.returncode != 0:
        raise SystemExit(f"{' '.join(args)}: {done.stderr.strip()}")
    doc: dict[str, object] = json.loads(done.stdout.strip().splitlines()[-1])
    return doc


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--scene", default="tabletop_pick_place", help="the scene generated in")
    ap.add_argument("--source-scene", default=None, help="the scene the sources are recorded in (default: --scene)")
    ap.add_argument("--sources", type=int, default=10)
    ap.add_argument("--n", type=int, default=40, help="attempts")
    ap.add_argument("--workers", type=int, nargs="+", default=[1])
    ap.add_argument("--codec", default="av1")
    args = ap.parse_args()
    tmp = Path(tempfile.mkdtemp(prefix="bench-generate-"))
    try:
        src = tmp / "source"
        run("record", "--scene", args.source_scene or args.scene, "--n-episodes", str(args.sources), "--out", str(src))
        rows = []
        for workers in args.workers:
            out = tmp / f"gen-{workers}"
            t0 = time.perf_counter()
            doc = run(
                "generate", str(src), "--scene", args.scene, "--n", str(args.n), "--out", str(out),
                "--workers", str(workers), "--codec", args.codec,
            )  # fmt: skip
            seconds = time.perf_counter() - t0
            replayed = run("replay", str(out), "--mode", "actions", "--out", str(tmp / f"replay-{workers}"))
            row = {
                "workers": workers,
                "attempts": doc["attempts"],
                "kept": doc["kept"],
                "keep_rate": doc["keep_rate"],
                "frames": doc["frames"],
                "seconds": round(seconds, 1),
                "kept_per_minute": round(60 * int(str(doc["kept"])) / seconds, 2),
                "replay_success": replayed["success_replayed"],
                "replay_reproduced": replayed["reproduced"],
            }
            rows.append(row)
            print(json.dumps(row), flush=True)
        result = {"scene": args.scene, "sources": args.sources, "runs": rows}
        dest = Path("benchmarks/results")
        dest.mkdir(parents=True, exist_ok=True)
        (dest / f"generate-{args.scene}.json").write_text(json.dumps(result, indent=2))
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    main()
