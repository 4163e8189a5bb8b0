"""The episode flow for a person at the robot: `--episode-time-s` (an episode records that long), `--reset-time-s`
(a countdown between episodes, nothing recorded, space skips it), the prompts with the task text, `--view` on a
HAL session, and who drove every episode (`operator`, the `episodes` SQL view's column).

An episode of S seconds at F fps is the ticks due in its first S seconds, round(S * F): as many frames when no
tick was missed or stale, one fewer when the loaded machine missed a tick (the tolerance below, ±1).
"""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
import termios
import threading
import time
import urllib.request
from collections.abc import Callable
from pathlib import Path
from urllib.parse import quote

import numpy as np
import pytest

from openral_data.record.hal import HalRecordOptions, record_hal
from openral_data.runtime import registry
from tests.support.feetech_bus import SimulatedFeetechBus, calibrated_so_project
from tests.support.hal import episode_infos, frames_table
from tests.support.inproc import run_inproc
from tests.support.live import connect_client, entities, free_port_pair, settled, stop_rerun
from tests.support.pty_terminal import Terminal, cli_on_pty

SO = "so101_follower"
SWEEP = "sweep-so-arm"
SWEEP_TASK = registry.resolve_rskill(SWEEP)[0].description
HAL = ("record", "--hal", SO, "--rskill", SWEEP, "--codec", "h264")


def _lengths(out: Path) -> dict[int, list[int]]:
    """episode -> its frames' `openral.tick`."""
    cols = frames_table(out)
    ticks: dict[int, list[int]] = {}
    for e, t in zip(cols["episode_index"], cols["openral.tick"], strict=True):
        ticks.setdefault(int(e), []).append(int(t))
    return ticks


def _timed(ticks: list[int], n: int) -> None:
    """An episode that ran its time: ticks 0..n-1 were due, each frame is one of them (a missed one: ±1)."""
    assert n - 1 <= len(ticks) <= n and max(ticks) <= n - 1, (ticks, n)


def _sql(out: Path, query: str) -> list[dict[str, object]]:
    r = run_inproc("stats", str(out), "--sql", query, "--format", "json")
    assert r.returncode == 0, r.stderr
    rows: list[dict[str, object]] = json.loads(r.stdout)["sql"]
    return rows


def test_timed_episodes_and_reset_wait_on_the_twin(project: Path, tmp_path: Path) -> None:
    out = tmp_path / "twin"
    t0 = time.monotonic()
    r = run_inproc(
        *HAL, "--fps", "20", "--episode-time-s", "0.5", "--reset-time-s", "0.5", "--n-episodes", "2",
        "--out", str(out),
    )  # fmt: skip
    took = time.monotonic() - t0
    assert r.returncode == 0, r.stderr
    lines = r.stderr.splitlines()
    assert lines[0] == f"episode 1/2: recording, 0.5 s — {SWEEP_TASK}"
    assert lines[1].startswith("episode 1/2: kept (time_limit, ")
    assert lines[2] == "reset: 0.5 s to reset the scene — space starts episode 2/2 now (q quits)"
    assert lines[3] == f"episode 2/2: recording, 0.5 s — {SWEEP_TASK}"
    assert lines[4].startswith("episode 2/2: kept (time_limit, ") and len(lines) == 5, lines  # no reset after the last
    assert "verdicts              time_limit, time_limit" in r.stdout
    ticks = _lengths(out)
    assert sorted(ticks) == [0, 1]
    for e in ticks.values():
        _timed(e, 10)  # round(0.5 s * 20 fps)
    assert took >= 0.5 * 3  # two episodes and the reset between them
    assert [i["hal"]["verdict"] for i in episode_infos(out)] == ["time_limit", "time_limit"]
    rows = _sql(out, "SELECT episode_index, success, operator FROM episodes ORDER BY episode_index")
    assert rows == [{"episode_index": e, "success": None, "operator": "script:sweep-so-arm"} for e in (0, 1)]


@pytest.mark.parametrize("flag", ["-q", "--json"])
def test_prompts_are_quiet_under_q_and_json(project: Path, tmp_path: Path, flag: str) -> None:
    args = [*HAL, "--fps", "20", "--episode-time-s", "0.2", "--out", str(tmp_path / "o")]
    r = run_inproc(*(["-q", *args] if flag == "-q" else [*args, "--json"]))
    assert r.returncode == 0, r.stderr
    assert "episode 1/1" not in r.stderr and "reset" not in r.stderr, r.stderr
    if flag == "--json":
        doc = json.loads(r.stdout)
        assert doc["verdicts"] == ["time_limit"] and doc["episode_list"][0]["length"] in (3, 4)


@pytest.mark.parametrize(
    ("args", "message"),
    [
        ([*HAL, "--episode-time-s", "0"], "error: --episode-time-s must be > 0 and finite, got 0.0"),
        ([*HAL, "--episode-time-s", "-2"], "error: --episode-time-s must be > 0 and finite, got -2.0"),
        ([*HAL, "--episode-time-s", "nan"], "error: --episode-time-s must be > 0 and finite, got nan"),
        ([*HAL, "--episode-time-s", "inf"], "error: --episode-time-s must be > 0 and finite, got inf"),
        ([*HAL, "--episode-time-s", "0.01"], "error: --episode-time-s: 0.01 s is less than one frame at 20 fps"),
        ([*HAL, "--reset-time-s", "0"], "error: --reset-time-s must be > 0 and finite, got 0.0"),
        ([*HAL, "--reset-time-s", "-1"], "error: --reset-time-s must be > 0 and finite, got -1.0"),
        (
            ["record", "--scene", "mock_pick", "--episode-time-s", "2", "--reset-time-s", "1"],
            "error: --episode-time-s, --reset-time-s: only with --hal ROBOT_ID or --teleop",
        ),
    ],
)
def test_bad_times_are_refused_before_anything_is_written(
    project: Path, tmp_path: Path, args: list[str], message: str
) -> None:
    out = tmp_path / "o"
    r = run_inproc(*args, "--out", str(out))
    assert r.returncode == 2 and r.stderr.startswith(message), r.stderr
    assert r.stderr.strip().splitlines() == [r.stderr.strip()]
    assert not out.exists()


@pytest.mark.slow  # a subprocess on a pty with lerobot's driver on a simulated bus, and 2 s of reset: ~15 s
def test_a_person_at_the_so_arm_times_resets_and_decides(project: Path, tmp_path: Path) -> None:
    """The real CLI on a pty with lerobot's SOFollower on a SIMULATED Feetech bus: space starts, `s` ends the
    first episode as a success, space skips the first reset, the second reset runs out and starts the third
    episode by itself; the timed episodes are round(1.5 s * 10 fps) = 15 frames (±1) and say `time_limit`."""
    calibrated_so_project(project, SO)
    out = tmp_path / "so"
    with SimulatedFeetechBus(list(range(1, 7))) as bus:
        args = [*HAL[1:], "--mode", "real", "--port", bus.port, "--fps", "10", "--operator", "keyboard"]
        times = ["--episode-time-s", "1.5", "--reset-time-s", "2", "--n-episodes", "3", "--out", str(out)]
        with cli_on_pty(["record", *args, *times], Terminal) as (proc, term):
            _, at = term.wait_for(f"episode 1/3: {SWEEP_TASK} — press space to start (q quits)".encode(), 60)
            term.type(" ")
            _, at = term.wait_for(b"episode 1/3: recording, 1.5 s", 10, at)
            time.sleep(0.5)  # a few frames (a verdict before the first frame leaves an empty episode: discarded)
            term.type("s")
            _, at = term.wait_for(b"episode 1/3: kept (success, ", 10, at)
            reset1, at = term.wait_for(b"reset: 2 s to reset the scene", 10, at)
            term.type(" ")  # skip the reset
            start2, at = term.wait_for(b"episode 2/3: recording, 1.5 s", 10, at)
            _, at = term.wait_for(b"episode 2/3: kept (time_limit, ", 10, at)
            reset2, at = term.wait_for(b"reset: 2 s to reset the scene", 10, at)
            _, at = term.wait_for(b"reset: 1 s", 10, at)  # the countdown
            start3, at = term.wait_for(b"episode 3/3: recording, 1.5 s", 10, at)  # nobody pressed space
            _, at = term.wait_for(b"episode 3/3: kept (time_limit, ", 10, at)
            proc.wait(timeout=30)
            term.read(0.2)
    text = term.text.decode(errors="replace")
    assert proc.returncode == 0, text[-2000:]
    assert start2 - reset1 < 1.5, text  # space skipped the 2 s reset
    assert start3 - reset2 > 1.8, text  # the 2 s reset ran out (the pty read polls every 0.05 s)
    assert "press space to start" not in text.split("episode 1/3: recording")[1]  # a reset's end starts the next
    ticks = _lengths(out)
    assert sorted(ticks) == [0, 1, 2]
    assert 1 <= len(ticks[0]) < 15  # `s` ended it early
    _timed(ticks[1], 15)
    _timed(ticks[2], 15)
    cols = frames_table(out)
    real = np.array(cols["openral.real_timestamp"])
    assert real.max() < 1.5 + 0.2  # within each episode's own time: nothing was recorded during a reset
    infos = episode_infos(out)
    assert [i["hal"]["verdict"] for i in infos] == ["success", "time_limit", "time_limit"]
    assert {i["operator"] for i in infos} == {"script:sweep-so-arm"}
    rows = _sql(out, "SELECT success FROM episodes ORDER BY episode_index")
    assert [row["success"] for row in rows] == [True, None, None]


def _typist(master: int, slave: int, *keys: tuple[Callable[[], bool], bytes]) -> threading.Thread:
    """A person typing each key once its condition holds (polled), after the operator reads keys: its terminal
    left canonical mode (switching flushes what was typed before, so a key typed earlier would be lost)."""

    def run() -> None:
        deadline = time.monotonic() + 60
        for ready, key in [(lambda: not termios.tcgetattr(slave)[3] & termios.ICANON, b""), *keys]:
            while not ready() and time.monotonic() < deadline:
                time.sleep(0.02)
            os.write(master, key)

    thread = threading.Thread(target=run, daemon=True)
    thread.start()
    return thread


def test_a_teleop_sim_session_is_timed(project: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """`record --scene tabletop_push --teleop keyboard` through the real CLI with stdin on a pty: one space starts
    the session, each episode records round(0.5 s * fps) frames (±1), the reset's end starts the next."""
    scene = registry.resolve_scene_path("tabletop_push")
    from openral_data.schemas.scene import load_recordable_scene

    loaded = load_recordable_scene(scene)
    fps, task = loaded.scene.fps, loaded.task.instruction
    out = tmp_path / "teleop"
    master, slave = os.openpty()
    try:
        with os.fdopen(slave, "r", closefd=True) as stdin:
            monkeypatch.setattr(sys, "stdin", stdin)
            _typist(master, slave, (lambda: True, b" "))
            r = run_inproc(
                "record", "--scene", "tabletop_push", "--teleop", "keyboard", "--episode-time-s", "0.5",
                "--reset-time-s", "0.3", "--n-episodes", "2", "--out", str(out), "--codec", "h264",
            )  # fmt: skip
    finally:
        os.close(master)
    assert r.returncode == 0, r.stderr
    assert f"episode 1/2: {task} — press space to start (q quits)" in r.stderr
    assert f"episode 2/2: recording, 0.5 s — {task}" in r.stderr
    ticks = _lengths(out)
    for e in (0, 1):
        _timed(ticks[e], round(0.5 * fps))
    infos = episode_infos(out)
    assert [i["operator"] for i in infos] == ["teleop:keyboard"] * 2
    assert [i["hal"]["verdict"] for i in infos] == ["time_limit"] * 2


def test_the_e_stop_key_works_during_the_reset(project: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    out = tmp_path / "estop"
    committed = out / "meta" / "episodes"
    master, slave = os.openpty()
    t0 = time.monotonic()
    try:
        with os.fdopen(slave, "r", closefd=True) as stdin:
            monkeypatch.setattr(sys, "stdin", stdin)
            # space starts episode 1; `x` once it is committed, in the 30 s reset
            _typist(master, slave, (lambda: True, b" "), (lambda: any(committed.rglob("*.parquet")), b"x"))
            r = run_inproc(
                *HAL, "--fps", "20", "--operator", "keyboard", "--episode-time-s", "0.3", "--reset-time-s", "30",
                "--n-episodes", "2", "--out", str(out),
            )  # fmt: skip
    finally:
        os.close(master)
    assert r.returncode == 1, r.stderr  # an e-stop ends the run with exit 1
    assert time.monotonic() - t0 < 25  # the reset did not run out
    assert "e-stop: operator e-stop (between episodes)" in r.stderr and "episode 2/2: recording" not in r.stderr
    assert "e-stop                operator e-stop (between episodes)" in r.stdout
    assert sorted(_lengths(out)) == [0]  # the first episode is kept


@pytest.mark.parametrize(
    ("rskill", "driver"), [("random-mock", "policy:random-mock"), ("zero-mock", "policy:zero-mock")]
)
def test_every_scene_recording_says_who_drove(project: Path, tmp_path: Path, rskill: str, driver: str) -> None:
    out = tmp_path / rskill
    r = run_inproc("record", "--scene", "mock_pick", "--rskill", rskill, "--n-episodes", "2", "--out", str(out))
    assert r.returncode == 0, r.stderr
    rows = _sql(out, "SELECT DISTINCT operator FROM episodes")
    assert rows == [{"operator": driver}]


def test_a_scripted_expert_is_a_script(project: Path, tmp_path: Path) -> None:
    out = tmp_path / "push"
    r = run_inproc(
        "record", "--scene", "tabletop_push", "--n-episodes", "1", "--max-steps", "3", "--out", str(out),
        "--codec", "h264",
    )  # fmt: skip
    assert r.returncode == 0, r.stderr
    assert _sql(out, "SELECT operator FROM episodes") == [{"operator": "script:scripted-push"}]


@pytest.mark.slow  # a rerun client process
def test_view_streams_a_hal_session(
    project: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    port = free_port_pair()
    got = tmp_path / "client.rrd"
    client: list[subprocess.Popen[bytes]] = []

    def notify(line: str) -> None:
        if " kept (" in line and not client:  # after the first episode a client connects to the served stream
            client.append(connect_client(f"rerun+http://127.0.0.1:{port}/proxy", got))

    opts = HalRecordOptions(
        robot=SO, rskill=SWEEP, fps=20, n_episodes=2, episode_time_s=0.3, out=tmp_path / "v", codec="h264",
        view=True, view_port=port,
    )  # fmt: skip
    s = record_hal(opts, notify)
    assert client
    settled(got)
    stop_rerun(client[0])
    stream = f"rerun+http://127.0.0.1:{port}/proxy"  # a page a person opens headless, and the stream it shows
    page = f"http://127.0.0.1:{port + 1}/?url={quote(stream, safe='')}"
    assert f"view: open {page} (or: rerun --connect {stream})" in capsys.readouterr().err.splitlines()
    with urllib.request.urlopen(page, timeout=10) as r:  # rerun's web viewer, served by the recording process
        assert b"re_viewer" in r.read()
    received = {rid: v for rid, v in entities(got).items() if "-episode-" in rid}
    assert sorted(rid.rsplit("-", 1)[1] for rid in received) == ["0", "1"]
    for temporal, _ in received.values():
        assert any(e.startswith("/state/") for e in temporal) and any(e.startswith("/action/") for e in temporal)
        assert "/events" in temporal  # the start was shown before the episode recorded (the preview's note)
    assert s.frames == sum(r.frames for r in s.reports) and math.isclose(s.frames, 12, abs_tol=2)
