"""Action-replay overhead on `tabletop_push`: `replay --mode actions` vs stepping the same scene with the same
actions without the replay machinery.

Workload: a `tabletop_push` dataset recorded here (franka_panda, scripted-push expert, `--episodes` episodes
from seed 0, one 64x64 camera; untimed). Both contestants run in one process, alternating, `--repeats` times
each; the ratio uses the medians:

1. **baseline**: build the scene from the same recorded config with no cameras (what replay renders), then per
   episode `reset_to(initial state)` and `step` every recorded action, the actions already in memory as numpy
   arrays. Nothing is read, compared or written.
2. **replay**: `openral_data.replay.replay(ReplayOptions(dataset))`: open the dataset, rebuild the scene from
   `meta/openral.json`, read each episode's rows from parquet, restore, step, per-frame divergence, success
   check, and write the results directory (summary.json, episodes.parquet, steps.parquet).

One untimed warm-up of each comes first. overhead = replay / baseline - 1, for wall time and for the process's
CPU time. Both contestants step the same actions; the script checks the step counts match.

Run from the repository root::

    .venv/bin/python benchmarks/bench_replay.py                      # 10 episodes, 5 repeats
    .venv/bin/python benchmarks/bench_replay.py --episodes 3 --repeats 1
"""

from __future__ import annotations

import argparse
import os
import shutil
import tempfile
from pathlib import Path

import numpy as np
import yaml

os.environ.setdefault("MUJOCO_GL", "egl")
os.environ.setdefault("HF_HUB_OFFLINE", "1")

from timing import Stopwatch, Timing, alternate, overhead_table, run_line

from openral_data.record.options import RecordOptions
from openral_data.record.sim import record
from openral_data.replay import ReplayOptions, replay
from openral_data.replay.recorded import RecordedDataset
from openral_data.runtime import registry


def make_dataset(folder: Path, episodes: int) -> Path:
    data = yaml.safe_load(registry.resolve_scene_path("tabletop_push").read_text())
    data["scene"]["cameras"] = [{**data["scene"]["cameras"][0], "width": 64, "height": 64}]
    scene = folder / "push_64.yaml"
    scene.write_text(yaml.safe_dump(data, sort_keys=False))
    out = folder / "push"
    record(RecordOptions(scene=str(scene), rskill="scripted-push", n_episodes=episodes, seed=0, out=out, codec="h264"))
    return out


def load_workload(dataset: Path) -> tuple[object, list[tuple[dict[str, object], np.ndarray]]]:
    """The recorded scene config and every episode's (initial state, actions), in memory (untimed)."""
    ds = RecordedDataset(dataset)
    scene = ds.scene()
    scene = scene.model_copy(update={"scene": scene.scene.model_copy(update={"cameras": []})})
    episodes = []
    for e in range(len(ds)):
        ep = ds.episode(e)
        assert ep.initial_state is not None
        episodes.append((ep.initial_state, ep.actions))
    return (scene, ds.robot(), ds.rskill()), episodes


def baseline(config: object, episodes: list[tuple[dict[str, object], np.ndarray]]) -> Timing:
    scene, robot, rskill = config  # type: ignore[misc]
    with Stopwatch() as sw:
        env = registry.SCENES[scene.scene.type](scene, registry.ROBOTS[robot], rskill, "baseline")
        steps = 0
        try:
            for initial, actions in episodes:
                env.reset_to(initial)
                for action in actions:
                    steps += 1
                    if env.step(action).terminated:
                        break
        finally:
            env.close()
    return sw.timing(steps)


def replayed(dataset: Path, out: Path) -> Timing:
    shutil.rmtree(out, ignore_errors=True)
    with Stopwatch() as sw:
        summary = replay(ReplayOptions(dataset, out=out))
    if summary.summary["reproduced"] != len(summary.episodes):
        raise SystemExit(f"replay did not reproduce every episode: {summary.summary}")
    return sw.timing(sum(o.steps for o in summary.episodes))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--episodes", type=int, default=10)
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        dataset = make_dataset(folder, args.episodes)
        config, episodes = load_workload(dataset)
        baseline(config, episodes[:1])  # warm-up: imports, first compile
        replayed(dataset, folder / "res")

        def on_run(k: int, base: Timing, rep: Timing) -> None:
            sb, sr = base[2], rep[2]
            if sb != sr:
                raise SystemExit(f"baseline stepped {sb} steps but replay {sr}: not the same workload")
            print(run_line(k, base, rep, "replay", "steps", 2), flush=True)

        base, rep = alternate(
            args.repeats, lambda: baseline(config, episodes), lambda: replayed(dataset, folder / "res"), on_run
        )
        sr = rep[-1][2]
        print(f"\ntabletop_push, {args.episodes} episodes, {sr} steps, median of {args.repeats}:")
        header = "| | baseline (reset_to + step) | replay --mode actions | overhead |"
        print(overhead_table(header, "CPU", base, rep, 2))


if __name__ == "__main__":
    main()
