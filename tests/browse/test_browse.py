"""`browse` in a real Chromium (Debian's, driven by Playwright) against the real server: the table's rows, the
--where filter, a video sought to frame k showing frame k (drawn to a canvas, compared with the frame PyAV
decodes from the dataset's mp4), the plot's series, the selection's command (run, it does what it says), and
traversal URLs refused with 404 over a real socket."""

from __future__ import annotations

import http.client
import json
import shlex
import signal
import subprocess
import sys
import urllib.request
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import av
import numpy as np
import pytest

from openral_data.browse import Browser, open_catalogs
from openral_data.metrics.sources import open_dataset
from tests.browse.pages import GRAB, plots
from tests.support.inproc import run_inproc
from tests.support.lerobot_written import LENGTHS


@pytest.fixture(scope="module")
def server(browse_dataset: Path) -> Iterator[Browser]:
    browser = Browser(open_catalogs([str(browse_dataset)]))
    browser.start()
    yield browser
    browser.close()


def _rows(page: Any) -> list[list[str]]:
    return [
        [c.strip() for c in row]
        for row in page.eval_on_selector_all(
            "#episodes tbody tr",
            "rows => rows.map(r => [...r.querySelectorAll('td')].slice(1).map(td => td.textContent))",
        )
    ]


def test_table_renders_the_episodes_and_where_narrows_them(server: Browser, page: Any) -> None:
    page.goto(server.url + "d/0/")
    page.wait_for_function("() => document.querySelectorAll('#episodes tbody tr').length === 3")
    rows = _rows(page)
    assert [r[0] for r in rows] == ["0", "1", "2"]
    assert [int(r[2]) for r in rows] == LENGTHS
    assert [r[4] for r in rows] == ["true", "false", "true"]
    assert page.text_content("#summary").startswith("3 episodes; success 2/3 = 66.7 %")
    page.fill("#where", "length > 5")
    page.click("#filter button")
    page.wait_for_function("() => document.querySelectorAll('#episodes tbody tr').length === 2")
    assert [r[0] for r in _rows(page)] == ["0", "1"]
    assert page.text_content("#summary").startswith("2 episodes; success 1/2")
    page.click("th[data-column=length]")  # sort by length, ascending, on the server
    page.wait_for_function("() => document.querySelector('#episodes tbody tr').dataset.episode === '0'")


def _decoded(root: Path, at: float) -> np.ndarray:
    """The dataset's frame shown at `at` seconds into its (only) mp4, as PyAV decodes it (RGB)."""
    (mp4,) = (root / "videos").rglob("*.mp4")
    with av.open(str(mp4)) as container:
        for frame in container.decode(video=0):
            if frame.time is not None and frame.time >= at - 1e-3:
                return frame.to_ndarray(format="rgb24")
    raise AssertionError(f"no frame at {at}")


def test_episode_video_plays_and_seeks_to_frame_k(server: Browser, page: Any, browse_dataset: Path) -> None:
    page.goto(server.url + "d/0/episode/1")
    page.wait_for_selector("body[data-ready='1']")
    start = float(page.get_attribute("video", "data-from"))
    for k in (8, 4, 0):
        pixels = np.array(page.evaluate(GRAB, [k, 10]), dtype=np.float64).reshape(32, 32, 4)[..., :3]
        want = _decoded(browse_dataset, start + k / 10).astype(np.float64)
        assert np.abs(pixels - want).mean() < 3, k  # frames differ by 10 grey levels: k is told from k +- 1
    played = page.evaluate(
        """async () => {
          const v = document.querySelector('video');
          const t0 = v.currentTime;
          await v.play();
          // until the clock moves (a loaded machine may take longer than any fixed wait to start it)
          const deadline = performance.now() + 20000;
          while (v.currentTime <= t0 && performance.now() < deadline) {
            await new Promise(r => setTimeout(r, 50));
          }
          return [t0, v.currentTime, Number(v.dataset.to)];
        }"""
    )
    assert played[0] < played[1] <= played[2]  # it played, within the episode (its end: test_episode_page.py)


def test_plot_shows_the_named_series(server: Browser, page: Any) -> None:
    assert plots(page, server.url + "d/0/episode/1") == [
        ["observation.state", [["x", 9], ["y", 9], ["z", 9]]],
        ["action", [["vx", 9], ["vy", 9]]],
    ]
    assert page.text_content("#task") == "push the block"


def test_selection_prints_the_command_that_does_it(server: Browser, page: Any, browse_dataset: Path) -> None:
    page.goto(server.url + "d/0/")
    page.wait_for_function("() => document.querySelectorAll('#episodes tbody tr').length === 3")
    page.check("#episodes tbody tr[data-episode='1'] input[type=checkbox]")
    page.wait_for_selector("#command-delete")
    command = page.text_content("#command-delete")
    args = shlex.split(command)
    assert args[:3] == ["openral-data", "episodes", "delete"]
    out = Path(args[args.index("--out") + 1])
    try:
        assert run_inproc(*args[1:]).returncode == 0
        assert open_dataset(out).info["total_episodes"] == 2  # episode 1 (9 frames) gone
        assert open_dataset(out).info["total_frames"] == LENGTHS[0] + LENGTHS[2]
    finally:
        import shutil

        shutil.rmtree(out, ignore_errors=True)


@pytest.mark.parametrize(
    "url", ["/..%2f..%2fetc%2fpasswd", "/../../etc/passwd", "//etc/passwd", "/static/..%2f_app.py", "/d/0/video/0/0/.."]
)
def test_traversal_urls_are_404_over_the_wire(server: Browser, url: str) -> None:
    host, port = server.sock.getsockname()[:2]
    conn = http.client.HTTPConnection(host, port, timeout=5)
    try:
        conn.request("GET", url)  # sent as written: no client-side normalisation
        assert conn.getresponse().status == 404
    finally:
        conn.close()


def test_the_command_prints_its_url_serves_and_stops_on_ctrl_c(browse_dataset: Path) -> None:
    cmd = [sys.executable, "-m", "openral_data.cli", "browse", str(browse_dataset), "--port", "0"]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        assert proc.stdout is not None
        line = proc.stdout.readline()
        url = line.split(" at ", 1)[1].split()[0]
        assert line.startswith("browse: serving 1 dataset(s) at http://127.0.0.1:")
        with urllib.request.urlopen(url + "api/datasets", timeout=10) as r:
            assert json.load(r)[0]["path"] == str(browse_dataset)
        proc.send_signal(signal.SIGINT)
        assert proc.wait(timeout=20) == 130  # the CLI's exit status for Ctrl-C, as for every command
        assert "Traceback" not in proc.communicate()[1]
    finally:
        proc.kill()
        proc.communicate()
