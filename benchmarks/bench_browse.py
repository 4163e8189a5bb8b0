"""`browse` on a large dataset: how long until the episodes table and an episode page are painted in a real
Chromium (Debian's, through Playwright), on a dataset of 10,000 episodes.

The dataset (unless ``--dataset`` names one already written) is written by ``LeRobotV3Writer`` through
``DatasetBridge``: ``--episodes`` (10,000) episodes of ``--length`` (5) frames at 20 fps, state/action
float32[7], one 64x64 camera in h264, frames from `bench_commits`'s pre-rendered pool. Then the server
(`openral_data.browse.Browser`, in a thread) and one headless Chromium; each figure is the wall time from
``page.goto`` to the page being usable, ``--repeat`` (5) times after one untimed warm-up, printed as
min/median/max:

* table: the first page of 50 rows is in the DOM (count, success interval and the page come from the server);
* table, filtered: the same with ``--where "length > 4 AND episode_index % 7 = 0"``, typed into the page;
* episode: the middle episode's page with its plot drawn and its video's first frame decoded (readyState >= 2).

Run (from the repository root)::

    .venv/bin/python benchmarks/bench_browse.py                             # 10,000 episodes (writes ~4 min)
    .venv/bin/python benchmarks/bench_browse.py --keep /tmp/browse10k       # keep the dataset for reruns
    .venv/bin/python benchmarks/bench_browse.py --dataset /tmp/browse10k    # reuse it
    .venv/bin/python benchmarks/bench_browse.py --episodes 200 --repeat 2   # smoke run

Old against new in one run (same machine, same load, same dataset): ``--baseline DIR`` names a folder holding an
older ``openral_data`` package (``git archive main openral_data | tar -x -C DIR``); each page is then measured
``--rounds`` (2) times with each tree, alternating (old, new, old, new: a load that drifts weighs on both), each in
its own process, and the ratio new / old of the medians is printed per page::

    .venv/bin/python benchmarks/bench_browse.py --dataset /tmp/browse10k --baseline /tmp/old
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_commits import TASK, frame_pool, schema, state

from openral_data.browse import Browser, open_catalogs
from openral_data.formats.lerobot_v3 import LeRobotV3Writer, VideoSettings, WriterConfig
from openral_data.runtime.bridge import DatasetBridge
from openral_data.types import Observation

FPS = 20
CHROMIUM = "/usr/bin/chromium"
WHERE = "length > 4 AND episode_index % 7 = 0"  # lengths alternate 5, 4: every 14th episode


def write(root: Path, episodes: int, length: int) -> None:
    """The dataset, as the writer lays it out, written the quick way: no fsync (a benchmark's input, not a
    recording to keep safe) and every episode staged until the close joins them all once (by default the writer
    joins each 1,000 staged episodes into the growing first file, rewriting it: at 10,000 episodes that made
    writing the input take hours on the loaded machine). The layout is the same: one data file of one row group
    per episode, one mp4."""
    sch = schema(1)
    config = WriterConfig(video=VideoSettings(codec="h264"), durable=False, staged_episodes=max(1, episodes))
    bridge = DatasetBridge(sch, [LeRobotV3Writer(root, sch, config)])
    pool = frame_pool()
    try:
        for e in range(episodes):
            bridge.begin_episode(e, {"seed": e})
            n = length - (e % 2)  # lengths differ, so a filter on length narrows
            for t in range(n):
                obs = Observation(
                    images={"cam0": pool[(e + t) % len(pool)]}, state=state(e, t), task=TASK, time=t / FPS
                )
                bridge.add_step(obs, state(e, t + 1), reward=0.0, done=t == n - 1, success=e % 3 == 0)
            bridge.end_episode(success=e % 3 == 0)
    finally:
        bridge.close()


def timed(page: Any, repeat: int, action: Any) -> list[float]:
    action(page)  # warm-up
    out = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        action(page)
        out.append(time.perf_counter() - t0)
    return out


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--episodes", type=int, default=10_000)
    p.add_argument("--length", type=int, default=5)
    p.add_argument("--repeat", type=int, default=5)
    p.add_argument("--dataset", type=Path, help="an existing dataset to browse (nothing written)")
    p.add_argument("--keep", type=Path, help="write the dataset here and keep it")
    p.add_argument("--baseline", type=Path, help="a folder with an older openral_data: measure old against new")
    p.add_argument("--rounds", type=int, default=2, help="with --baseline: old/new measurements of each")
    p.add_argument("--json", action="store_true", help=argparse.SUPPRESS)  # medians as JSON (--baseline's runs)
    args = p.parse_args(argv)
    tmp = Path(tempfile.mkdtemp(prefix="bench-browse-"))
    root = args.dataset or args.keep or tmp / "ds"
    try:
        if args.dataset is None:
            t0 = time.perf_counter()
            write(root, args.episodes, args.length)
            print(f"wrote {args.episodes} episodes in {time.perf_counter() - t0:.0f} s", flush=True)
        if args.baseline is not None:
            return against(root, args.repeat, args.baseline, args.rounds)
        return measure(root, args.repeat, args.json)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def against(root: Path, repeat: int, baseline: Path, rounds: int) -> int:
    """The medians of each page with the `baseline` tree's openral_data and with this one's, alternating, in
    separate processes; then new / old per page."""
    here = Path(__file__).resolve().parent.parent
    runs: dict[str, list[dict[str, float]]] = {"old": [], "new": []}
    for _ in range(rounds):
        for name, tree in (("old", baseline.resolve()), ("new", here)):
            cmd = [sys.executable, __file__, "--dataset", str(root), "--repeat", str(repeat), "--json"]
            env = {**os.environ, "PYTHONPATH": str(tree)}
            out = subprocess.run(cmd, env=env, cwd=tree, capture_output=True, text=True, check=True).stdout
            runs[name].append(json.loads(out.strip().splitlines()[-1]))
            print(f"{name}: " + ", ".join(f"{k} {v * 1000:.0f} ms" for k, v in runs[name][-1].items()), flush=True)
    for page in runs["new"][0]:
        old = statistics.median(r[page] for r in runs["old"])
        new = statistics.median(r[page] for r in runs["new"])
        print(f"{page:16s}: old {old * 1000:.0f} ms, new {new * 1000:.0f} ms, new/old {new / old:.2f}", flush=True)
    return 0


def measure(root: Path, repeat: int, as_json: bool = False) -> int:
    from playwright.sync_api import sync_playwright

    server = Browser(open_catalogs([str(root)]))
    server.start()
    total = int(server.catalogs[0].ds.info["total_episodes"])
    rows = "() => document.querySelectorAll('#episodes tbody tr').length > 0"

    def table(page: Any) -> None:
        page.goto(server.url + "d/0/")
        page.wait_for_function(rows)

    def filtered(page: Any) -> None:
        table(page)
        page.fill("#where", WHERE)
        page.click("#filter button")
        want = f"{len(range(0, total, 14))} episodes"
        page.wait_for_function(f"() => document.getElementById('summary').textContent.startsWith('{want}')")

    def episode(page: Any) -> None:
        page.goto(server.url + f"d/0/episode/{total // 2}")
        page.wait_for_selector("body[data-ready='1']")
        page.wait_for_function("() => document.querySelector('video').readyState >= 2")

    try:
        with sync_playwright() as pw:
            browser = pw.chromium.launch(executable_path=CHROMIUM)
            page = browser.new_page()
            medians = {}
            for name, action in (("table", table), ("table, filtered", filtered), ("episode", episode)):
                s = timed(page, repeat, action)
                medians[name] = statistics.median(s)
                if not as_json:
                    print(
                        f"{name:16s} ({total} episodes): min {min(s) * 1000:.0f} ms, median "
                        f"{statistics.median(s) * 1000:.0f} ms, max {max(s) * 1000:.0f} ms",
                        flush=True,
                    )
            browser.close()
            if as_json:
                print(json.dumps(medians), flush=True)
    finally:
        server.close()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
