"""Start-up of everyday commands: `openral-data --version`, `list scenes`, `list`, `info` and `doctor` on a small
dataset, each a fresh process (as a user's shell runs it), so the figure is mostly the interpreter plus the imports a
command pays.

Setup (untimed): a small mock recording (2 episodes of 48 steps, 96 frames, one h264 camera) made by the CLI in a
temporary project home, and a copy of it whose quality table `quality` computed (`info` then counts its flags);
one `list` fills the manifest cache (`runtime/catalog_cache.py`, in the temporary `XDG_CACHE_HOME`). Then
`--repeats` rounds; each round runs every command once, in turn (interleaved, so a burst of load on the machine
hits them all alike), and with `--against ROOT` the same commands of another checkout right after each (e.g. the
main checkout's, to compare). `list scenes (cold)` empties the manifest cache first: a first run after installing
or editing. The table shows per command the median, minimum and maximum wall seconds and the median CPU seconds
(user + system of the child process). The goal of issue 52: `list scenes` and `info` at most 0.5 CPU-s each.

Each checkout runs as `python -P -m openral_data.cli` with its root on `PYTHONPATH` (this one by default).

Run from the repository root::

    .venv/bin/python benchmarks/bench_startup.py                  # 7 rounds
    .venv/bin/python benchmarks/bench_startup.py --against ../main
    .venv/bin/python benchmarks/bench_startup.py --repeats 1      # smoke run
"""

from __future__ import annotations

import argparse
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

from timing import run_child

REPO = Path(__file__).resolve().parent.parent


def _env(home: Path, root: Path) -> dict[str, str]:
    # bytecode caching on, as on a user's machine (PYTHONDONTWRITEBYTECODE would recompile our modules each run)
    drop = ("VIRTUAL_ENV", "PYTHONDONTWRITEBYTECODE")
    env = {k: v for k, v in os.environ.items() if k not in drop}
    env.update(
        PYTHONPATH=str(root),
        OPENRAL_DATA_HOME=str(home),
        XDG_CONFIG_HOME=str(home / "config"),
        XDG_CACHE_HOME=str(home / "cache"),
        HF_HUB_OFFLINE="1",
    )
    env.setdefault("MUJOCO_GL", "egl")
    return env


def _timed(cmd: list[str], env: dict[str, str], cold: bool = False) -> tuple[float, float]:
    """Wall and CPU (user + system) seconds of one run of `cmd`, which must succeed; `cold`: with no manifest
    cache (it is removed first, untimed)."""
    if cold:
        shutil.rmtree(Path(env["XDG_CACHE_HOME"]) / "openral-data", ignore_errors=True)
    done, wall, cpu = run_child(cmd, env)
    if done.returncode != 0:
        sys.exit(f"{' '.join(cmd)}: exit {done.returncode}\n{done.stderr}")
    return wall, cpu


def _setup(home: Path, env: dict[str, str]) -> tuple[Path, Path]:
    """The small recording, and a copy of it with its quality table computed."""
    cli = [sys.executable, "-P", "-m", "openral_data.cli", "-q"]
    ds, rated = home / "datasets" / "small", home / "datasets" / "rated"
    make = [*cli, "record", "--n-episodes", "2", "--max-steps", "48", "--codec", "h264", "--out", str(ds)]
    subprocess.run(make, env=env, check=True, capture_output=True)
    shutil.copytree(ds, rated)
    subprocess.run([*cli, "quality", str(rated)], env=env, check=True, capture_output=True)
    return ds, rated


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=7)
    parser.add_argument("--against", type=Path, help="another checkout's root, run right after each command")
    args = parser.parse_args()
    roots = {"this": REPO} | ({"other": args.against.resolve()} if args.against else {})
    with tempfile.TemporaryDirectory(prefix="bench-startup-") as tmp:
        home = Path(tmp)
        envs = {label: _env(home / label, root) for label, root in roots.items()}
        sets = {label: _setup(home / label, env) for label, env in envs.items()}
        cli = [sys.executable, "-P", "-m", "openral_data.cli"]  # -P: the checkout on PYTHONPATH, not the cwd
        for env in envs.values():  # fills the manifest cache of each (where there is one)
            _timed([*cli, "list"], env)
        commands: dict[str, tuple[list[str], int, bool]] = {  # argv, which dataset, cold manifest cache
            "--version": (["--version"], 0, False),
            "list scenes": (["list", "scenes"], 0, False),
            "list scenes (cold)": (["list", "scenes"], 0, True),
            "list": (["list"], 0, False),
            "info": (["info"], 1, False),
            "info (quality)": (["info"], 2, False),
            "doctor": (["doctor"], 1, False),
        }
        runs: dict[tuple[str, str], list[tuple[float, float]]] = {}
        for _ in range(args.repeats):
            for name, (argv, which, cold) in commands.items():
                for label, env in envs.items():
                    data = [str(sets[label][which - 1])] if which else []
                    runs.setdefault((name, label), []).append(_timed([*cli, *argv, *data], env, cold))
    print(f"{args.repeats} rounds, interleaved; seconds (wall median [min-max], CPU median); {os.cpu_count()} CPUs")
    print(f"load average (1 min) at the end: {os.getloadavg()[0]:.1f}")
    for (name, label), timings in runs.items():
        walls = [w for w, _ in timings]
        cpu = statistics.median(c for _, c in timings)
        print(
            f"{name:18} {label:6} {statistics.median(walls):6.3f} [{min(walls):.3f}-{max(walls):.3f}]  "
            f"CPU {cpu:.3f}  ({roots[label]})"
        )


if __name__ == "__main__":
    main()
