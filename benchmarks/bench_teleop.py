"""Loop overruns of a keyboard teleop session: `openral-data record --scene tabletop_push --teleop keyboard` on a
pseudo-terminal, a scripted person pressing a move key every `--press-every` seconds (back and forth along x, so
the arm keeps moving and stays in reach) until the episode's `--max-steps` frames are recorded; then the
session summary's `overruns N (M ticks missed)` and the CPU time the process used from the start of the episode
(space pressed) to its exit (the episode, then closing the dataset). `--view` also serves the live view
(nobody opens its page: what the session costs with the view on). Rounds alternate the variants given, and with
`--against ROOT` run each session with another checkout right after (each as `python -P -m openral_data.cli` with
its root on PYTHONPATH).

Run from the repository root::

    MUJOCO_GL=egl .venv/bin/python benchmarks/bench_teleop.py                       # 3 rounds, with and without --view
    MUJOCO_GL=egl .venv/bin/python benchmarks/bench_teleop.py --rounds 1 --frames 60 --variants plain
"""

from __future__ import annotations

import argparse
import contextlib
import os
import re
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from tests.support.pty_terminal import Terminal  # noqa: E402

SUMMARY = re.compile(rb"frames\s+(\d+).*?overruns\s+(\d+) \((\d+) ticks missed\)", re.DOTALL)
VARIANTS = {"plain": [], "view": ["--view"]}
FPS = 20  # tabletop_push's


def session(root: Path, frames: int, codec: str, extra: list[str], press_every: float, port: int) -> dict[str, float]:
    """One episode of `frames` frames; its frames, overruns, missed ticks, wall and CPU seconds."""
    with tempfile.TemporaryDirectory(prefix="bench-teleop-") as tmp:
        out = Path(tmp) / "teleop"
        args = ["record", "--scene", "tabletop_push", "--teleop", "keyboard", "--n-episodes", "1", "--seed", "0"]
        args += ["--max-steps", str(frames), "--codec", codec, "--out", str(out), *extra]
        if "--view" in extra:
            args += ["--view-port", str(port)]
        master, slave = os.openpty()
        env = {**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl"), "PYTHONPATH": str(root)}
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        proc = subprocess.Popen(
            [sys.executable, "-P", "-m", "openral_data.cli", *args],  # -P: the checkout on PYTHONPATH
            stdin=slave, stdout=slave, stderr=slave, env=env, close_fds=True,
        )  # fmt: skip
        os.close(slave)
        term = Terminal(master)
        try:
            start, _ = term.wait_for(b"press space to start", 120)
            before_episode = _cpu(proc.pid)
            term.type(" ")
            key, last, samples = "i", 0.0, []  # (seconds since space, the process's CPU seconds)
            while proc.poll() is None:
                term.read(0.02)
                with contextlib.suppress(OSError, IndexError):  # (it exited meanwhile)
                    samples.append((time.monotonic() - start, _cpu(proc.pid)))
                if time.monotonic() - last >= press_every:
                    term.type(key)
                    key, last = ("k" if key == "i" else "i"), time.monotonic()
            proc.wait()
            term.read(0.2)
            wall = time.monotonic() - start
        finally:
            if proc.poll() is None:
                proc.kill()
                proc.wait()
            os.close(master)
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
    found = SUMMARY.search(term.text)
    if proc.returncode != 0 or found is None:
        sys.exit(f"record exited {proc.returncode}:\n{term.text[-3000:].decode(errors='replace')}")
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime) - before_episode
    n, overruns, missed = (int(found.group(i)) for i in (1, 2, 3))
    # cores busy while recording: CPU over the episode's middle (1 s after space to 1 s before its last frame)
    inside = [(t, c) for t, c in samples if 1.0 <= t <= n / FPS - 1.0]
    busy = (inside[-1][1] - inside[0][1]) / (inside[-1][0] - inside[0][0]) if len(inside) > 1 else float("nan")
    return {"frames": n, "overruns": overruns, "missed": missed, "wall": wall, "cpu": cpu, "busy": busy}


def _cpu(pid: int) -> float:
    """CPU seconds (user + system, all threads) process `pid` used so far."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--frames", type=int, default=200)
    parser.add_argument("--codec", default="h264")
    parser.add_argument("--press-every", type=float, default=0.15, help="seconds between key presses")
    parser.add_argument("--variants", default="plain,view", help=f"comma-separated, of {sorted(VARIANTS)}")
    parser.add_argument("--port", type=int, default=9911, help="--view: the stream's port (the page: the next)")
    parser.add_argument("--against", type=Path, help="another checkout's root: each session run with it too")
    args = parser.parse_args()
    roots = {"this": REPO} | ({"other": args.against.resolve()} if args.against else {})
    names = args.variants.split(",")
    runs: dict[tuple[str, str], list[dict[str, float]]] = {}
    for _ in range(args.rounds):
        for name in names:
            for label, root in roots.items():
                r = session(root, args.frames, args.codec, VARIANTS[name], args.press_every, args.port)
                runs.setdefault((name, label), []).append(r)
                counts = f"frames {r['frames']:.0f} overruns {r['overruns']:.0f} missed {r['missed']:.0f}"
                cpu = f"CPU {r['cpu']:.1f} s, {r['busy']:.2f} cores busy while recording"
                print(f"  {name:6} {label:6} {counts} wall {r['wall']:.1f} s {cpu}", flush=True)
    print(
        f"{args.rounds} rounds, {args.frames} frames at the scene's 20 fps, {args.codec}; {os.cpu_count()} CPUs; "
        f"load average (1 min) at the end {os.getloadavg()[0]:.1f}"
    )
    for (name, label), rs in runs.items():
        per100 = [100 * r["overruns"] / max(1, r["frames"]) for r in rs]
        busy = statistics.median(r["busy"] for r in rs)
        spread = f"{statistics.median(per100):.1f} [{min(per100):.1f}-{max(per100):.1f}]"
        print(f"{name:6} {label:6} overruns per 100 frames: median {spread}; cores busy while recording {busy:.2f}")


if __name__ == "__main__":
    main()
