"""Start-up of `record`: the scene built while the policy loads (the default) vs one after the other
(`OPENRAL_SEQUENTIAL_START=1`), on a MuJoCo scene with a real lerobot ACT checkpoint.

Setup (untimed): a small `tabletop_push` scene (one 64x64 front camera, the shipped physics), two scripted-push
episodes recorded on it, a tiny ACT checkpoint made from them (tests/support/checkpoint.py, nothing downloaded)
and an rSkill like the shipped `lerobot-act-push` pointing at it, all in a temporary project home.

Each run is a fresh `openral-data -v --log-format json record ... --n-episodes 1 --max-steps 1` process (cold:
the policy load includes importing torch and lerobot, as a user's first command does); its `started` log record
gives `env_ms`, `policy_ms` and `total_ms`. Concurrent and sequential runs alternate, `--repeats` times each; the
table shows the medians and the speed-up sequential ÷ concurrent of `total_ms` and of the process's wall time.

Run from the repository root::

    .venv/bin/python benchmarks/bench_start.py               # 5 repeats of each
    .venv/bin/python benchmarks/bench_start.py --repeats 1   # smoke run
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import yaml

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))
os.environ.setdefault("MUJOCO_GL", "egl")
os.environ.setdefault("HF_HUB_OFFLINE", "1")

from openral_data.record.start import SEQUENTIAL_ENV  # noqa: E402
from tests.support.checkpoint import make_act_checkpoint  # noqa: E402
from tests.support.home import isolated_home  # noqa: E402
from tests.support.replay import record_push, small_push_scene  # noqa: E402
from tests.support.scenes import write_yaml  # noqa: E402

RSKILL = "act-push-bench"
KEYS = ("env_ms", "policy_ms", "total_ms", "wall_ms")


def setup(home: Path, base: Path) -> Path:
    """The scene to record and, in `home`, the ACT rSkill on a checkpoint made from two recorded episodes."""
    dataset = record_push(home, base / "push", n_episodes=2).out
    checkpoint = make_act_checkpoint(dataset, base / "act")
    data = yaml.safe_load((home / "rskills/lerobot-act-push/rskill.yaml").read_text())
    data.update(id=RSKILL, policy_extras={"checkpoint": str(checkpoint), "device": "cpu"})
    write_yaml(home / f"rskills/{RSKILL}/rskill.yaml", data)
    return small_push_scene(home)


def one_start(scene: Path, out: Path, sequential: bool) -> dict[str, float]:
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}  # bytecode cached, as for a user
    env.update({SEQUENTIAL_ENV: "1" if sequential else "0", "PYTHONPATH": str(REPO)})
    args = ["-v", "--log-format", "json", "record", "--scene", str(scene), "--rskill", RSKILL]
    args += ["--n-episodes", "1", "--max-steps", "1", "--codec", "h264", "--out", str(out)]
    t0 = time.perf_counter()
    proc = subprocess.run(
        [sys.executable, "-m", "openral_data.cli", *args], capture_output=True, text=True, env=env, check=False
    )
    wall = (time.perf_counter() - t0) * 1000
    if proc.returncode != 0:
        raise SystemExit(f"record failed: {proc.stderr[-2000:]}")
    [started] = [r for r in map(json.loads, proc.stderr.splitlines()) if "total_ms" in r]
    assert started["concurrent"] is not sequential
    return {"env_ms": started["env_ms"], "policy_ms": started["policy_ms"], "total_ms": started["total_ms"],
            "wall_ms": wall}  # fmt: skip


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        base = Path(tmp)
        with isolated_home(base) as home:
            scene = setup(home, base)
            one_start(scene, base / "warmup", sequential=False)  # untimed: page cache, compiled bytecode
            runs: dict[bool, list[dict[str, float]]] = {False: [], True: []}
            for k in range(args.repeats):
                for sequential in (True, False):
                    run = one_start(scene, base / f"run-{k}-{int(sequential)}", sequential)
                    runs[sequential].append(run)
                    label = "sequential" if sequential else "concurrent"
                    print(f"run {k} {label:10} " + "  ".join(f"{key} {run[key]:7.0f}" for key in KEYS), flush=True)
    med = {s: {key: statistics.median(r[key] for r in runs[s]) for key in KEYS} for s in runs}
    print(f"\nmedians of {args.repeats} runs each (ms)")
    print("| start | env_ms | policy_ms | total_ms | process wall |")
    print("|---|---|---|---|---|")
    for sequential in (True, False):
        m = med[sequential]
        label = "sequential" if sequential else "concurrent"
        print(f"| {label} | {m['env_ms']:.0f} | {m['policy_ms']:.0f} | {m['total_ms']:.0f} | {m['wall_ms']:.0f} |")
    ratio = med[True]["total_ms"] / med[False]["total_ms"]
    wall = med[True]["wall_ms"] / med[False]["wall_ms"]
    print(f"\nspeed-up (sequential / concurrent): start {ratio:.2f}x, whole process {wall:.2f}x")


if __name__ == "__main__":
    main()
