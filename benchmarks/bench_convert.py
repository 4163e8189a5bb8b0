"""Bag -> LeRobot v3 conversion against our writer on the same frames, and `convert --workers 2`.

Workload W (``workload.py``'s renderer; smaller with ``--episodes/--frames``) is written once as bags by
our MCAP sink (one bag per episode, JPEG cameras, as ``record --format mcap`` writes them). Then, in a rotating
order in every round:

1. **writer**: ``LeRobotV3Writer`` behind ``DatasetBridge`` fed the decoded frames from memory (what the
   conversion ends in: ``bench_writer.py``'s "ours"),
2. **convert**: ``convert_bags`` of the folder of bags (mapping inferred from the bags), one process,
3. **convert x2**: ``convert_parallel`` of the same folder with 2 local worker processes.

Printed: convert rate / writer rate (the conversion's target is >= 0.8x) and the speed-up of --workers 2, each
the median of the per-round ratios. ``--profile`` runs one sequential conversion under cProfile instead and
prints where the time goes.

Run (from the repository root)::

    .venv/bin/python benchmarks/bench_convert.py                                      # W, 3 rounds
    .venv/bin/python benchmarks/bench_convert.py --episodes 4 --frames 40 --repeats 1  # smoke
    .venv/bin/python benchmarks/bench_convert.py --episodes 2 --frames 100 --profile   # where the time goes
"""

from __future__ import annotations

import argparse
import cProfile
import json
import os
import pstats
import shutil
import statistics
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_mcap import run_sink
from bench_writer import run_ours
from workload import Workload, make_data


def main(argv: list[str] | None = None) -> int:
    # bytecode caching on, as on a user's machine: with PYTHONDONTWRITEBYTECODE (set in some sandboxes) every
    # spawned worker would compile its imports from source again (bench_workers.py does the same)
    os.environ.pop("PYTHONDONTWRITEBYTECODE", None)
    sys.dont_write_bytecode = False
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--episodes", type=int, default=10)
    p.add_argument("--frames", type=int, default=200)
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--codec", choices=["av1", "h264"], default="av1")
    p.add_argument("--profile", action="store_true", help="profile one sequential conversion instead")
    p.add_argument("--out", type=Path, default=Path("benchmarks/results"))
    args = p.parse_args(argv)
    from openral_data.convert.own_bags import own_mapping
    from openral_data.convert.to_lerobot import convert_bags
    from openral_data.formats.mcap import finished_bags

    wl = Workload(episodes=args.episodes, frames=args.frames)
    scratch = Path(tempfile.mkdtemp(prefix="openral-bench-convert-"))
    try:
        data = make_data(wl)
        bags = scratch / "bags"
        bags.mkdir()
        run_sink(data, bags, wl)
        mapping = own_mapping(finished_bags(bags)[0])
        if args.profile:
            prof = cProfile.Profile()
            prof.enable()
            convert_bags(bags, scratch / "profiled", mapping, codec=args.codec)
            prof.disable()
            pstats.Stats(prof).sort_stats("tottime").print_stats(25)
            return 0

        def writer(root: Path) -> None:
            run_ours(data, root, wl, args.codec)

        def convert(root: Path) -> None:
            assert convert_bags(bags, root, mapping, codec=args.codec).frames == wl.total_frames

        def convert2(root: Path) -> None:
            from openral_data.convert.parallel import convert_parallel

            assert convert_parallel(bags, root, mapping, 2, codec=args.codec).frames == wl.total_frames

        contestants = {"writer": writer, "convert": convert, "convert x2": convert2}
        names = list(contestants)
        walls: dict[str, list[float]] = {n: [] for n in names}
        for rep in range(args.repeats):
            for name in names[rep % 3 :] + names[: rep % 3]:
                root = scratch / f"rep{rep}-{name.replace(' ', '')}"
                t0 = time.perf_counter()
                contestants[name](root)
                walls[name].append(time.perf_counter() - t0)
                shutil.rmtree(root)
                print(f"[{rep + 1}/{args.repeats}] {name:<10} {walls[name][-1]:6.2f}s "
                      f"{wl.total_frames / walls[name][-1]:7.1f} frames/s")  # fmt: skip
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
    ratio = [w / c for w, c in zip(walls["writer"], walls["convert"], strict=True)]
    speedup = [c / c2 for c, c2 in zip(walls["convert"], walls["convert x2"], strict=True)]
    result: dict[str, Any] = {
        "workload": {"episodes": wl.episodes, "frames": wl.frames, "cameras": list(wl.cameras), "fps": wl.fps},
        "codec": args.codec,
        "wall_s": walls,
        "convert_over_writer": ratio,
        "workers2_speedup": speedup,
    }
    print(f"convert rate / writer rate ({args.codec}), median of rounds: {statistics.median(ratio):.2f}x "
          f"(rounds: {', '.join(f'{x:.2f}' for x in ratio)})")  # fmt: skip
    print(f"convert --workers 2 speed-up, median of rounds: {statistics.median(speedup):.2f}x "
          f"(rounds: {', '.join(f'{x:.2f}' for x in speedup)})")  # fmt: skip
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / f"convert_results_{args.codec}.json").write_text(json.dumps(result, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
