"""`view --serve`: the episode kept in rerun's web viewer (the one bundled in the rerun wheel): the command prints
the viewer's URL, the viewer answers HTTP on its port and the stream on its own, and Ctrl-C stops both (exit 130)."""

from __future__ import annotations

import signal
import socket
import subprocess
import sys
import urllib.request
from pathlib import Path
from urllib.parse import parse_qs, urlparse

import pytest

from openral_data.errors import UsageError
from tests.support.inproc import run_inproc
from tests.support.lerobot_written import write_lerobot_dataset


def _free_ports(n: int) -> list[int]:
    socks = [socket.socket() for _ in range(n)]
    for s in socks:
        s.bind(("127.0.0.1", 0))
    ports = [s.getsockname()[1] for s in socks]
    for s in socks:
        s.close()
    return ports


@pytest.fixture(scope="module")
def dataset(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("serve") / "ds"
    write_lerobot_dataset(root, True)
    return root


def test_serves_the_web_viewer_until_ctrl_c(dataset: Path) -> None:
    web, grpc = _free_ports(2)
    cmd = [sys.executable, "-m", "openral_data.cli", "view", str(dataset), "--episode", "1", "--serve"]
    cmd += ["--web-port", str(web), "--grpc-port", str(grpc)]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        assert proc.stdout is not None
        line = proc.stdout.readline()
        assert line.startswith(f"view: serving {dataset} episode 1 (9 frames) at http://127.0.0.1:{web}/?url=")
        url = line.split(" at ", 1)[1].split()[0]
        assert parse_qs(urlparse(url).query)["url"] == [f"rerun+http://127.0.0.1:{grpc}/proxy"]
        with urllib.request.urlopen(url, timeout=10) as r:
            assert r.status == 200 and b"<html" in r.read().lower()
        with socket.create_connection(("127.0.0.1", grpc), timeout=5):
            pass  # the stream's port answers too
        proc.send_signal(signal.SIGINT)
        assert proc.wait(timeout=20) == 130
        assert "Traceback" not in proc.communicate()[1]
        with pytest.raises(OSError):
            urllib.request.urlopen(url, timeout=2)  # stopped with the process
    finally:
        proc.kill()
        proc.communicate()


def test_a_busy_port_or_save_is_one_line_before_serving(dataset: Path) -> None:
    from openral_data.viz.serve import serve_episode

    with socket.socket() as busy:
        busy.bind(("0.0.0.0", 0))
        busy.listen()
        with pytest.raises(UsageError, match=r"--web-port: .*cannot serve there"):
            serve_episode(dataset, 0, web_port=busy.getsockname()[1], grpc_port=_free_ports(1)[0])
    r = run_inproc("view", str(dataset), "--serve", "--save", "x.rrd")
    assert r.returncode == 2 and r.stderr.strip().startswith("error: --serve:")
