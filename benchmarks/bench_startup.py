"""Start-up of everyday commands: `openral-data --version`, `list`, `info` and `doctor` on a small dataset, each a fresh
process (as a user's shell runs it), so the figure is mostly the interpreter plus the imports a command pays.

Setup (untimed): a small mock recording (2 episodes of 48 steps, 96 frames, one h264 camera) made by the CLI in
a temporary project home. Then `--repeats` rounds; each round runs every command once, in turn (interleaved, so
a burst of load on the machine hits them all alike), and with `--against OTHER` the same commands of another
`openral-data` right after each (e.g. the main checkout's, to compare). The table shows per command the median,
minimum and maximum wall seconds and the median CPU seconds (user + system of the child process).

Run from the repository root::

    .venv/bin/python benchmarks/bench_startup.py                  # 7 rounds
    .venv/bin/python benchmarks/bench_startup.py --against ../main/.venv/bin/openral-data
    .venv/bin/python benchmarks/bench_startup.py --repeats 1      # smoke run
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

from timing import run_child

REPO = Path(__file__).resolve().parent.parent
HERE = REPO / ".venv" / "bin" / "openral-data"


def _env(home: Path) -> dict[str, str]:
    # bytecode caching on, as on a user's machine (PYTHONDONTWRITEBYTECODE would recompile our modules each run)
    drop = ("PYTHONPATH", "VIRTUAL_ENV", "PYTHONDONTWRITEBYTECODE")
    env = {k: v for k, v in os.environ.items() if k not in drop}
    env.update(OPENRAL_DATA_HOME=str(home), XDG_CONFIG_HOME=str(home / "config"), HF_HUB_OFFLINE="1")
    env.setdefault("MUJOCO_GL", "egl")
    return env


def _timed(cmd: list[str], env: dict[str, str]) -> tuple[float, float]:
    """Wall and CPU (user + system) seconds of one run of `cmd`, which must succeed."""
    done, wall, cpu = run_child(cmd, env)
    if done.returncode != 0:
        sys.exit(f"{' '.join(cmd)}: exit {done.returncode}\n{done.stderr}")
    return wall, cpu


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=7)
    parser.add_argument("--exe", type=Path, default=HERE, help="the openral-data measured (default: this .venv's)")
    parser.add_argument("--against", type=Path, help="another openral-data, run right after each command")
    args = parser.parse_args()
    exes = {"this": args.exe} | ({"other": args.against} if args.against else {})
    with tempfile.TemporaryDirectory(prefix="bench-startup-") as tmp:
        home = Path(tmp)
        env = _env(home)
        ds = home / "datasets" / "small"
        make = [str(args.exe), "-q", "record", "--n-episodes", "2", "--max-steps", "48", "--codec", "h264"]
        subprocess.run([*make, "--out", str(ds)], env=env, check=True, capture_output=True)
        commands = {
            "--version": ["--version"],
            "list": ["list"],
            "info": ["info", str(ds)],
            "doctor": ["doctor", str(ds)],
        }
        runs: dict[tuple[str, str], list[tuple[float, float]]] = {}
        for _ in range(args.repeats):
            for name, argv in commands.items():
                for label, exe in exes.items():
                    runs.setdefault((name, label), []).append(_timed([str(exe), *argv], env))
    print(f"{args.repeats} rounds, interleaved; seconds (wall median [min-max], CPU median); {os.cpu_count()} CPUs")
    print(f"load average (1 min) at the end: {os.getloadavg()[0]:.1f}")
    for (name, label), timings in runs.items():
        walls = [w for w, _ in timings]
        cpu = statistics.median(c for _, c in timings)
        print(
            f"{name:10} {label:6} {statistics.median(walls):6.3f} [{min(walls):.3f}-{max(walls):.3f}]  "
            f"CPU {cpu:.3f}  ({exes[label]})"
        )


if __name__ == "__main__":
    main()
