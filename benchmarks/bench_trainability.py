"""Trainability: does a small policy trained on our recorded expert demos work in closed loop?

Records `--demos` expert episodes of tabletop_push with `scripted-push`
(`pipelines/scenes/tabletop_push_small.yaml`: one 64x64 front camera; with `--state-only`
`tabletop_push_state.yaml`: the cube's and the goal's poses as `observation.environment_state`, its camera removed
before training), optionally injects one data fault into every episode (`tests/support/data_faults.py`:
`quaternion_flip`, `upside_down`, or `shuffled_instructions` = its `shuffle_tasks`; with `--state-only`,
`quaternion_flip` flips the cube's quaternion in the environment state, which data_faults' episodes do not carry),
trains ACT with lerobot's own trainer (`lerobot-train`, through the `train` step's
`openral_data/pipeline/trainer.py`, CPU, no pretrained weights) in blocks of `--block` steps, each resuming the
last, until `--cpu-minutes` of the trainer processes' CPU time or `--steps`, then records the checkpoint with
`record --policy` on `--eval` seeds from 100000 (never recorded as demos) and prints the success rate with its
Wilson 95 % interval. One JSON line per row is appended to `--results`.

    .venv/bin/python benchmarks/bench_trainability.py --work /tmp/trainability --state-only \
        --demos 100 --eval 50 --steps 6000 --block 2000 --batch-size 32 [--defect quaternion_flip]

lerobot-train runs with `--threads` (1) torch threads: with torch's default (one per core) its OpenMP threads
spin-wait for each other on a busy machine, a camera step's update costing 5.1 CPU-s instead of 0.72.

Results and what was (not) measured: benchmarks/README.md "Trainability".
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
SCENES = {
    "camera": ROOT / "pipelines" / "scenes" / "tabletop_push_small.yaml",  # the flywheel campaign's scene
    "state": ROOT / "pipelines" / "scenes" / "tabletop_push_state.yaml",  # cube + goal poses, camera removed
}
EVAL_SEED = 100_000
CLI = [sys.executable, "-m", "openral_data.cli"]


def cli(cmd: list[str]) -> str:
    done = subprocess.run([*CLI, *cmd], check=False, capture_output=True, text=True, cwd=ROOT)
    if done.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)}: exit {done.returncode}: {done.stderr[-2000:]}")
    return done.stdout


def record(scene: Path, out: Path, args: list[str]) -> dict[str, object]:
    if (out / "meta" / "info.json").is_file():
        return {"cached": str(out)}
    cmd = ["record", "--scene", str(scene), "--codec", "h264", "--out", str(out), "--json", *args]
    return dict(json.loads(cli(cmd)))


def without_camera(dataset: Path, out: Path) -> Path:
    """`dataset` without its camera (`features remove`): ACT then reads the state and the environment state."""
    if not (out / "meta" / "info.json").is_file():
        cli(["features", "remove", str(dataset), "--feature", "observation.images.front", "--out", str(out)])
    return out


def faulted(clean: Path, defect: str, out: Path) -> Path:
    """`clean` with `defect` injected into every episode (the quality helper's injector)."""
    if (out / "meta" / "info.json").is_file():
        return out
    sys.path.insert(0, str(ROOT))
    from tests.support import data_faults  # merged from the quality calibration branch

    info = json.loads((clean / "meta" / "info.json").read_text())
    episodes = [data_faults.load(clean, e) for e in range(int(info["total_episodes"]))]
    if defect == "shuffled_instructions":
        try:
            episodes, _ = data_faults.shuffle_tasks(episodes)
        except data_faults.NotApplicable as exc:  # one task: nothing to shuffle (and ACT reads no instruction)
            raise SystemExit(f"shuffled_instructions: not applicable: {exc}") from None
    else:
        episodes = [data_faults.inject(ep, defect, seed=i)[0] for i, ep in enumerate(episodes)]
    return data_faults.write(out, episodes)


def flipped_object_quaternion(clean: Path, out: Path) -> Path:
    """`clean` with the sign of the first quaternion of `observation.environment_state` (the cube's pose) flipped
    in every episode from a frame drawn in its middle half on (`data_faults.state_fault`'s rule, there applied to
    `observation.state`, which a state-only policy reads besides), then `stats recompute` (as a converter that
    flipped it would have written its statistics)."""
    if (out / "meta" / "info.json").is_file():
        return out
    import shutil

    import numpy as np
    import pyarrow as pa
    import pyarrow.parquet as pq

    sys.path.insert(0, str(ROOT))
    from tests.support.data_faults import quaternion_dims

    key = "observation.environment_state"
    names = tuple(json.loads((clean / "meta" / "info.json").read_text())["features"][key]["names"])
    quat = list(quaternion_dims(names) or ())
    if not quat:
        raise SystemExit(f"quaternion_flip: no quaternion among {key}'s names {names}")
    raw = out.with_name(out.name + ".raw")
    shutil.rmtree(raw, ignore_errors=True)
    shutil.copytree(clean, raw)
    for file in sorted((raw / "data").rglob("*.parquet")):
        table = pq.read_table(file)
        env = np.stack(table[key].to_numpy(zero_copy_only=False)).astype(np.float32)
        episodes = table["episode_index"].to_numpy()
        for e in np.unique(episodes):
            rows = np.flatnonzero(episodes == e)
            n = len(rows)
            k = int(np.random.default_rng(int(e)).integers(n // 4, 3 * n // 4))
            env[np.ix_(rows[k:], quat)] *= -1  # the same rotation from frame k on, its sign flipped
        column = pa.array(list(env), type=table.schema.field(key).type)
        pq.write_table(table.set_column(table.schema.get_field_index(key), key, column), file)
    cli(["stats", "recompute", str(raw), "--out", str(out)])
    shutil.rmtree(raw)
    return out


def train(dataset: Path, run: Path, a: argparse.Namespace) -> tuple[Path, int, float]:
    """`lerobot-train` in blocks of `--block` steps (each resuming the last) until the CPU budget or `--steps`;
    (checkpoint, steps, CPU s of the lerobot-train subprocesses: user + system, all threads)."""
    import resource

    from openral_data.pipeline.trainer import TrainSettings, done_steps, train_policy

    def cpu() -> float:
        r = resource.getrusage(resource.RUSAGE_CHILDREN)
        return r.ru_utime + r.ru_stime

    budget, start, steps = a.cpu_minutes * 60, cpu(), done_steps(run / "run")
    spent = float(json.loads((run / "cpu.json").read_text())["cpu_s"]) if (run / "cpu.json").is_file() else 0.0
    checkpoint = run / "run" / "checkpoints" / "last" / "pretrained_model"
    while steps < a.steps and (add := block_fitting(a.block, steps, spent + cpu() - start, budget)) > 0:
        steps = min(a.steps, steps + add)
        settings = TrainSettings(
            steps=steps,
            batch_size=a.batch_size,
            save_freq=a.block,
            seed=a.seed,
            chunk_size=a.chunk_size,
            n_action_steps=a.n_action_steps,
            temporal_ensemble_coeff=a.temporal_ensemble,
            dim_model=a.dim_model,
            dim_feedforward=4 * a.dim_model,
            n_encoder_layers=a.layers,
            lr=a.lr,
        )
        checkpoint, _ = train_policy(dataset, run / "run", settings, a.threads)
        print(f"step {steps}: {spent + cpu() - start:.0f} CPU-s", flush=True)
        (run / "cpu.json").write_text(json.dumps({"cpu_s": spent + cpu() - start, "steps": steps}))
    return checkpoint, done_steps(run / "run"), spent + cpu() - start


def block_fitting(block: int, steps: int, used: float, budget: float) -> int:
    """The steps of the next block: `block`, fewer when the CPU-seconds a step has cost so far (start-ups
    included) say a whole block would overrun `budget`; 0 when not even a tenth of a block fits."""
    if steps == 0 or used <= 0:
        return block if used < budget else 0
    fit = int((budget - used) * steps / used)
    return min(block, fit) if fit >= block // 10 else 0


def evaluate(scene: Path, checkpoint: Path, out: Path, n: int, max_steps: int) -> tuple[int, int]:
    seeds = ["--seed", str(EVAL_SEED), "--n-episodes", str(n)]
    summary = record(scene, out, ["--policy", str(checkpoint), *seeds, "--max-steps", str(max_steps)])
    if "cached" in summary:
        info = json.loads((out / "meta" / "info.json").read_text())
        raise SystemExit(f"{out} exists ({info['total_episodes']} episodes); remove it to evaluate again")
    return int(str(summary["successes"])), int(str(summary["episodes"]))


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--work", type=Path, required=True)
    p.add_argument("--demos", type=int, default=50)
    p.add_argument("--eval", type=int, default=20)
    p.add_argument("--defect", choices=["quaternion_flip", "upside_down", "shuffled_instructions"])
    p.add_argument("--cpu-minutes", type=float, default=30.0)
    p.add_argument("--steps", type=int, default=20_000)
    p.add_argument("--block", type=int, default=500)
    p.add_argument("--batch-size", type=int, default=16)
    p.add_argument("--dim-model", type=int, default=128)
    p.add_argument("--layers", type=int, default=1, help="ACT encoder layers")
    p.add_argument("--lr", type=float, default=1e-4)
    p.add_argument("--chunk-size", type=int, default=20)
    p.add_argument("--n-action-steps", type=int, default=1, help="actions executed per query (1: closed loop)")
    p.add_argument("--temporal-ensemble", type=float, default=None, help="ACT's coefficient (needs n-action-steps 1)")
    p.add_argument("--state-only", action="store_true", help="ACT on state + cube/goal poses, no camera")
    p.add_argument("--threads", type=int, default=1, help="torch's CPU threads in lerobot-train (trainer.threads_env)")
    p.add_argument("--seed", type=int, default=1000)
    p.add_argument("--max-steps", type=int, default=120, help="per evaluation episode (the expert needs ~45)")
    p.add_argument("--results", type=Path, default=None)
    a = p.parse_args()
    from openral_data.metrics.intervals import wilson

    a.work.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    if a.state_only and a.defect not in (None, "quaternion_flip"):
        raise SystemExit(f"{a.defect}: not applicable with --state-only (no camera; one instruction, unread)")
    kind = "state" if a.state_only else "camera"
    scene, demos = SCENES[kind], a.work / ("demos-state-cam" if a.state_only else "demos")
    expert = ["--rskill", "scripted-push", "--seed", "0", "--n-episodes", str(a.demos), "--keep", "success"]
    print(f"demos: {record(scene, demos, expert)}", flush=True)
    name = a.defect or "clean"
    if a.state_only:  # data_faults' episodes carry no environment state: the cube's quaternion is flipped here
        dataset = without_camera(demos, a.work / f"{demos.name}-nocam")
        if a.defect is not None:
            dataset = flipped_object_quaternion(dataset, a.work / f"{dataset.name}-{name}")
    else:
        dataset = demos if a.defect is None else faulted(demos, a.defect, a.work / f"{demos.name}-{name}")
    checkpoint, steps, cpu_s = train(dataset, a.work / f"run-{kind}-{name}", a)
    k, n = evaluate(scene, checkpoint, a.work / f"eval-{kind}-{name}-{steps}", a.eval, a.max_steps)
    ci = wilson(k, n)
    row = {
        "task": "tabletop_push (franka_panda)", "inputs": "state + cube/goal poses" if a.state_only else
        "state + front 64x64", "policy": "act", "dim_model": a.dim_model, "layers": a.layers, "lr": a.lr,
        "threads": a.threads, "defect": name, "demos": a.demos, "steps": steps, "batch_size": a.batch_size,
        "train_cpu_minutes": round(cpu_s / 60, 1), "eval_seeds": f"{EVAL_SEED}..{EVAL_SEED + n - 1}",
        "eval_max_steps": a.max_steps, "successes": k, "episodes": n,
        "wilson_low": round(ci.low, 3), "wilson_high": round(ci.high, 3),
        "wall_minutes": round((time.perf_counter() - t0) / 60, 1),
    }  # fmt: skip
    print(json.dumps(row), flush=True)
    with (a.results or a.work / "results.jsonl").open("a") as f:
        f.write(json.dumps(row) + "\n")


if __name__ == "__main__":
    main()
