"""Running the app: open the datasets, bind the socket first (port 0 = a free one, known before serving, so the
URL printed is the real one), then uvicorn on that socket, in the foreground or (tests) in a thread."""

from __future__ import annotations

import itertools
import socket
import threading
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import uvicorn

from openral_data.browse._app import create_app
from openral_data.browse._catalog import Catalog
from openral_data.browse._results import ResultSet, attach
from openral_data.errors import UsageError
from openral_data.metrics.sources import resolve


def open_catalogs(paths: Sequence[str]) -> list[Catalog]:
    """A `Catalog` per dataset named, with the results folders named (replay/eval) attached to the dataset they
    were computed on (`_results.attach`); results without any dataset are refused in one line."""
    datasets, results = resolve(list(paths))
    if results and not datasets:
        raise UsageError(f"browse: {results[0].root}: results alone; give the dataset too (browse DATASET RESULTS)")
    attached = attach(datasets, results)
    # the command-line spelling of each dataset (for the commands): the argument that named its folder, if any
    spelled = {Path(p).resolve(): p for p in paths}
    number = itertools.count()
    shown = [[ResultSet(r, next(number)) for r in found] for found in attached]  # read (or refused) first
    return [
        Catalog(ds, spelled.get(ds.root.resolve(), str(ds.root)), sets)
        for ds, sets in zip(datasets, shown, strict=True)
    ]


@dataclass
class Browser:
    """The server over `catalogs`, bound to `host:port` on creation; `url` is where it answers."""

    catalogs: list[Catalog]
    host: str = "127.0.0.1"
    port: int = 0
    rerun_url: str | None = None
    sock: socket.socket = field(init=False)
    server: uvicorn.Server = field(init=False)
    thread: threading.Thread | None = field(default=None, init=False)

    def __post_init__(self) -> None:
        family = socket.AF_INET6 if ":" in self.host else socket.AF_INET
        self.sock = socket.socket(family, socket.SOCK_STREAM)
        self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            self.sock.bind((self.host, self.port))
        except OSError as exc:
            self.sock.close()
            raise UsageError(f"--host/--port: cannot listen on {self.host}:{self.port}: {exc.strerror}") from None
        self.sock.listen(128)
        app = create_app(self.catalogs, self.rerun_url, self.host, self.sock.getsockname()[1])
        config = uvicorn.Config(app, log_level="warning", access_log=False, lifespan="off")
        self.server = uvicorn.Server(config)

    @property
    def url(self) -> str:
        host, port = self.sock.getsockname()[:2]
        return f"http://{f'[{host}]' if ':' in host else host}:{port}/"

    def run(self) -> None:
        """Serve until interrupted (Ctrl-C)."""
        try:
            self.server.run(sockets=[self.sock])
        finally:
            self.close()

    def start(self) -> None:
        """Serve from a background thread; returns once it answers."""
        self.thread = threading.Thread(target=self.server.run, kwargs={"sockets": [self.sock]}, daemon=True)
        self.thread.start()
        deadline = time.monotonic() + 10
        while not self.server.started and time.monotonic() < deadline:
            time.sleep(0.01)

    def close(self) -> None:
        self.server.should_exit = True
        if self.thread is not None:
            self.thread.join(10)
        self.sock.close()
        for c in self.catalogs:
            c.close()
