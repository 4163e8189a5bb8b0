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
"""

from __future__ import annotations

import argparse
import os
import shutil
import tempfile
from pathlib import Path

import yaml

os.environ.setdefault("MUJOCO_GL", "egl")
os.environ.setdefault("HF_HUB_OFFLINE", "1")

from rollouts import roll_out
from timing import Stopwatch, Timing, alternate, overhead_table, run_line

from openral_data.producers.sim.mujoco.scene import TabletopScene
from openral_data.record import registry
from openral_data.record.options import RecordOptions
from openral_data.record.sim import record
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


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--episodes", type=int, default=5)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--size", type=int, default=256)
    parser.add_argument("--codec", choices=["av1", "h264"], default="av1")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        scene_path = bench_scene(folder, args.size)
        # warm-up, untimed: first imports of the writer's modules (pyarrow, PyAV, ...) and GL/driver setup
        baseline(scene_path, 1)
        recorded(scene_path, 1, args.codec, folder / "ds")

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
