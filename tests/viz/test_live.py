"""`record --view`: a headless run serves a stream a rerun client receives the episodes from, the dataset stays
frame-exact, a blocked viewer never holds the recording back (live frames are dropped and counted), and bad
`--view*` options are one line before anything is written."""

from __future__ import annotations

import io
import re
import socket
import subprocess
import threading
import time
from dataclasses import replace
from pathlib import Path
from urllib.parse import quote

import numpy as np
import pyarrow.parquet as pq
import pytest
import rerun as rr

from openral_data.errors import UsageError
from openral_data.record.options import RecordOptions
from openral_data.record.sim import record
from openral_data.types import CameraShape, DatasetSchema, EpisodeRecord, EpisodeStart, Frame
from openral_data.viz.live import LiveView, open_live_view
from tests.support.cli import run_cli
from tests.support.lerobot import verify_mock_dataset
from tests.support.live import connect_client, entities, free_port, free_port_pair, settled, stop_rerun
from tests.support.rrd import RERUN
from tests.support.scenes import mock_scene, write_yaml

# a client stopped with Ctrl-C leaves an .rrd without the footer; RrdReader reads it by scanning
pytestmark = pytest.mark.filterwarnings("ignore:RRD file has no footer")

LENGTHS = [4, 6]
SCHEMA = DatasetSchema(
    fps=20,
    state_names=("a", "b"),
    action_names=("x",),
    cameras={"front": CameraShape(8, 8)},
    robot_type="mock",
)


def frame(t: int) -> Frame:
    return Frame(
        state=np.array([t, 0], np.float32),
        action=np.array([0.5], np.float32),
        images={"front": np.full((8, 8, 3), t % 256, np.uint8)},
        task="pick",
        reward=0.0,
        done=False,
        success=False,
        timestamp=t / 20,
    )


def test_a_blocked_viewer_never_holds_the_recording_back(tmp_path: Path) -> None:
    release = threading.Event()

    def connect(rec: rr.RecordingStream) -> None:  # the viewer thread is stuck here until released
        release.wait(30)
        rec.save(tmp_path / "live.rrd")

    err = io.StringIO()
    view = LiveView(SCHEMA, connect, max_pending=8, run_id="run", err=err)
    view.begin_episode(0, EpisodeStart(seed=0, initial_state={}))
    t0 = time.perf_counter()
    for t in range(200):
        view.add_frame(frame(t))
    spent = time.perf_counter() - t0
    view.end_episode(EpisodeRecord(index=0, length=200, success=True, seed=0))
    assert view.stats.dropped == 192  # 8 waited for the viewer, the rest were dropped at once
    assert spent < 1.0, spent  # (generous: the 200 calls take microseconds; a blocking put would never return)
    release.set()
    view.close()
    assert err.getvalue() == "view: 8 frames shown, 192 dropped (the viewer lagged)\n"
    temporal, static = entities(tmp_path / "live.rrd")["run-episode-0"]
    assert temporal["/state/a"] == temporal["/outcome/reward"] == 8
    assert temporal["/cameras/front"] == 4  # pictures at 10 Hz of a 20 fps episode: frames 0, 2, 4, 6
    assert temporal["/events"] == 1
    assert "/task" in static


@pytest.mark.slow
def test_record_view_serves_a_stream_a_client_receives(
    project: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    scene = write_yaml(project / "scenes/sim/mock_test.yaml", mock_scene(success_after=LENGTHS, n_episodes=2))
    port = free_port_pair()  # the stream, and rerun's web viewer on the next port
    url = f"rerun+http://127.0.0.1:{port}/proxy"
    got = tmp_path / "client.rrd"
    client: list[subprocess.Popen[bytes]] = []

    def progress(rec: EpisodeRecord | None, frames: int, total: int) -> None:
        if rec is None or client:
            return
        # after the first episode: a client connects to the served stream and saves what it receives
        client.append(connect_client(url, got))

    base = RecordOptions(scene=str(scene), rskill="random-mock", codec="h264")
    viewed = record(replace(base, out=tmp_path / "viewed", view=True, view_port=port), progress)
    assert client
    settled(got)  # the served stream lasts as long as this process: the client is stopped once all arrived
    stop_rerun(client[0])
    lines = capsys.readouterr().err.splitlines()
    assert f"view: open http://127.0.0.1:{port + 1}/?url={quote(url, safe='')} (or: rerun --connect {url})" in lines
    shown = [m for line in lines if (m := re.fullmatch(r"view: (\d+) frames shown, (\d+) dropped.*", line))]
    assert len(shown) == 1 and int(shown[0][1]) + int(shown[0][2]) == sum(LENGTHS)

    received = {rid: v for rid, v in entities(got).items() if "-episode-" in rid}
    assert sorted(rid.rsplit("-", 1)[1] for rid in received) == ["0", "1"]
    total = 0
    for rid, (temporal, static) in received.items():
        n = temporal["/outcome/reward"]
        total += n
        expected = {"/outcome/reward", "/outcome/success", "/outcome/done"}
        expected |= {e for e in temporal if e.startswith(("/state/", "/action/"))}
        assert {e: temporal[e] for e in expected} == dict.fromkeys(expected, n), rid
        # the pictures at most 10 a second: every other frame of the 20 fps episode, the first included
        assert temporal["/cameras/front"] == temporal["/cameras/wrist"] == (n + 1) // 2, rid
        assert any(e.startswith("/state/") for e in temporal) and any(e.startswith("/action/") for e in temporal)
        assert temporal["/events"] == 1 and "/task" in static
    assert total == int(shown[0][1])

    # the dataset is what a run without --view records, frame for frame
    plain = record(replace(base, out=tmp_path / "plain"))
    assert [e.length for e in viewed.episodes] == [e.length for e in plain.episodes] == LENGTHS
    seen = verify_mock_dataset(tmp_path / "viewed", "pyav")
    assert seen["lengths"] == LENGTHS
    data = "data/chunk-000/file-000.parquet"
    assert pq.read_table(tmp_path / "viewed" / data).equals(pq.read_table(tmp_path / "plain" / data))


def test_a_busy_port_is_one_line_before_anything_is_written(project: Path, tmp_path: Path) -> None:
    with socket.socket() as busy:
        busy.bind(("0.0.0.0", 0))
        busy.listen()
        port = busy.getsockname()[1]
        out = tmp_path / "ds"
        proc = run_cli("record", "--view", "--view-port", str(port), "--out", str(out), env={"DISPLAY": ""})
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr.splitlines()[0].startswith(f"error: --view-port: {port}: cannot serve there")
    assert not out.exists()


@pytest.mark.parametrize(
    ("args", "first"),
    [
        (["--view", "--workers", "2"], "error: --view, --view-port, --view-address: need --view"),
        (["--view-port", "9000"], "error: --view, --view-port, --view-address: need --view"),
        (["--view", "--view-address", "http://x"], "error: --view-address: 'http://x': expected rerun+http://"),
    ],
)
def test_view_options_that_do_not_combine(project: Path, tmp_path: Path, args: list[str], first: str) -> None:
    proc = run_cli("record", *args, "--out", str(tmp_path / "ds"))
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr.splitlines()[0].startswith(first), proc.stderr
    assert not (tmp_path / "ds").exists()


def test_open_live_view_refuses_a_bad_address() -> None:
    with pytest.raises(UsageError) as err:
        open_live_view(SCHEMA, address="rerun+http://127.0.0.1:9/nope")
    assert err.value.code == "usage"


def test_view_address_sends_to_a_running_viewer(tmp_path: Path) -> None:
    port = free_port()
    got = tmp_path / "server.rrd"
    server = subprocess.Popen(
        [str(RERUN), "--save", str(got), "--port", str(port)], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL
    )
    try:
        deadline = time.monotonic() + 30
        while time.monotonic() < deadline:  # until it listens
            with socket.socket() as s:
                if s.connect_ex(("127.0.0.1", port)) == 0:
                    break
            time.sleep(0.05)
        err = io.StringIO()
        view = open_live_view(SCHEMA, address=f"rerun+http://127.0.0.1:{port}/proxy", err=err)
        view.begin_episode(3, EpisodeStart(seed=3, initial_state={}))
        for t in range(5):
            view.add_frame(frame(t))
        view.end_episode(EpisodeRecord(index=3, length=5, success=True, seed=3))
        view.begin_episode(4, EpisodeStart(seed=4, initial_state={}))
        view.add_frame(frame(0))
        view.end_episode(None)  # discarded (Ctrl-C): the view says so
        view.close()
        assert err.getvalue().splitlines()[-1] == "view: 6 frames shown, 0 dropped (the viewer lagged)"
        settled(got)
    finally:
        stop_rerun(server)
    received = {rid.rsplit("-", 1)[1]: v for rid, v in entities(got).items()}
    assert {k: v[0]["/state/a"] for k, v in received.items()} == {"3": 5, "4": 1}
    assert {k: v[0]["/cameras/front"] for k, v in received.items()} == {"3": 3, "4": 1}  # 10 Hz: frames 0, 2, 4
    assert received["3"][0]["/events"] == received["4"][0]["/events"] == 1
