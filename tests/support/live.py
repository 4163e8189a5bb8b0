"""Watching a served `--view` stream in tests: a free port, a client's .rrd settling, the entities it received."""

from __future__ import annotations

import signal
import socket
import subprocess
import time
import warnings
from collections import Counter
from pathlib import Path

from rerun.chunk import RrdReader

from tests.support.rrd import RERUN


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def free_port_pair() -> int:
    """A port free with the next one (a served stream and its web page: `record --view` headless)."""
    while True:
        port = free_port()
        with socket.socket() as s:
            try:
                s.bind(("0.0.0.0", port + 1))
            except OSError:
                continue
        return port


def settled(path: Path, quiet: float = 1.5, limit: float = 30) -> None:
    """Wait until `path` stopped growing for `quiet` seconds."""
    size, since, deadline = -1, time.monotonic(), time.monotonic() + limit
    while time.monotonic() < deadline:
        now = path.stat().st_size
        if now != size:
            size, since = now, time.monotonic()
        elif time.monotonic() - since >= quiet:
            return
        time.sleep(0.1)
    raise AssertionError(f"{path} kept growing for {limit} s")


def entities(rrd: Path) -> dict[str, tuple[Counter[str], set[str]]]:
    """recording id -> (temporal rows per entity, static entities)."""
    with warnings.catch_warnings():  # a killed rerun (`stop_rerun`) leaves no footer: read by a whole-file scan
        warnings.filterwarnings("ignore", "RRD file has no footer")
        reader = RrdReader(rrd)
    out: dict[str, tuple[Counter[str], set[str]]] = {}
    for store in reader.recordings():
        temporal: Counter[str] = Counter()
        static: set[str] = set()
        for chunk in reader.stream(store=store):
            if chunk.is_static:
                static.add(chunk.entity_path)
            else:
                temporal[chunk.entity_path] += chunk.num_rows
        out[store.recording_id] = (temporal, static)
    return out


def connect_client(url: str, got: Path) -> subprocess.Popen[bytes]:
    """A rerun client connected to the served stream at `url`, saving what it receives to `got`; returned once data
    arrived (then it is connected: the server buffers what came before)."""
    client = subprocess.Popen(
        [str(RERUN), "--connect", url, "--save", str(got), "--port", "0"],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    deadline = time.monotonic() + 30
    while not (got.exists() and got.stat().st_size > 1000) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert got.exists() and got.stat().st_size > 1000, "the rerun client received nothing"
    return client


def stop_rerun(proc: subprocess.Popen[bytes], grace: float = 60) -> None:
    """Stop a rerun process that saves to an .rrd once what it received has `settled`: Ctrl-C, and if a loaded
    machine keeps it from exiting within `grace` seconds, SIGKILL. Either way the file holds every message that
    arrived (a killed rerun only leaves out the footer; `entities` reads such a file by a whole-file scan)."""
    proc.send_signal(signal.SIGINT)
    try:
        proc.wait(grace)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait()
