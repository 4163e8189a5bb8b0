"""An .rrd file written by us from rerun's in-memory stream, never by rerun's own file sink.

rerun 0.41's file sink writes on a thread of its own: on a full disk that thread stops, says why only in its own
log, and `flush` then either raises or — racing with the thread's end — waits forever (CI hung there twice).
So the recording goes to `rec.binary_stream()`; a thread of ours moves the encoded bytes into a hidden sibling
of the output while the episode is logged (memory stays bounded), and `close` takes the rest, fsyncs and renames
the file into place. A failed write is an ordinary `OSError` in our code: the hidden file is removed and nothing
is left under the output's name.

Each non-empty `read` of rerun 0.41's binary stream is a whole RRD stream of its own (header, messages and a
footer whose manifest indexes that part only), so the hidden file of a long episode holds several. A viewer
reading the footers, and `rerun rrd verify` ("More than one RRD manifest"), take that for a corrupt file. When
more than one part was written, rerun's own `rerun rrd route` joins them into one stream with one manifest
(without decoding the payloads; about 0.2 s), into a second hidden sibling that is moved into place.
"""

from __future__ import annotations

import os
import subprocess
import threading
from pathlib import Path
from types import TracebackType

import rerun as rr

from openral_data.errors import WriteError
from openral_data.formats.atomic import move_into_place, tmp_name

DRAIN_EVERY = 0.1  # s between two moves of encoded bytes from rerun's memory into the file
FINAL_FLUSH = 120.0  # s rerun may take to encode what is still queued when the episode is logged
ROUTE_TIMEOUT = 600.0  # s `rerun rrd route` may take to join the parts (it copies, without decoding)


class RrdFile:
    """`with RrdFile(rec, path):` everything `rec` logs inside the block ends up in `path` (written only when the
    block ends without an exception; else nothing is left)."""

    def __init__(self, rec: rr.RecordingStream, path: Path) -> None:
        self.path = path
        self._tmp = tmp_name(path)
        self._joined = tmp_name(tmp_name(path))  # the parts joined into one stream, when there are several
        self._parts = 0  # non-empty reads written: each one is an RRD stream of its own
        self._stream = rr.binary_stream(recording=rec)
        self._stop = threading.Event()
        self._error: OSError | None = None
        self._fd = -1
        self._thread = threading.Thread(target=self._drain_loop, name="rrd-file", daemon=True)

    def __enter__(self) -> RrdFile:
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            self._tmp.unlink(missing_ok=True)  # a stale one from a killed run
            self._fd = os.open(self._tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o644)
        except OSError as exc:  # a folder that cannot be written (read-only, no permission, not a folder)
            raise self._failed(exc) from exc
        self._thread.start()
        return self

    def __exit__(self, kind: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None) -> None:
        self._stop.set()
        self._thread.join()
        try:
            if kind is None:
                self._finish()
        finally:
            self._close(quiet=kind is not None or self._error is not None)

    def _close(self, quiet: bool) -> None:
        """Close the file and remove the hidden copy (gone already once renamed into place); a failure is one line
        unless another one is already on its way (`quiet`)."""
        failed: OSError | None = None
        try:
            os.close(self._fd)
        except OSError as exc:
            failed = exc
        try:
            self._tmp.unlink(missing_ok=True)
        except OSError as exc:
            failed = failed or exc
        if failed is not None and not quiet:
            raise self._failed(failed) from failed

    def _finish(self) -> None:
        if self._error is None:
            try:
                rest = self._stream.read(flush=True, flush_timeout_sec=FINAL_FLUSH)
            except RuntimeError as exc:  # rerun did not encode the queue in time: not a file-system error
                raise WriteError(f"{self.path}: cannot write the recording: {exc}") from exc
            self._write(rest)
        if self._error is not None:
            raise self._failed(self._error) from self._error
        try:
            if self._parts > 1:
                self._join()
                move_into_place(self._joined, self.path)
            else:
                move_into_place(self._tmp, self.path)
        except OSError as exc:
            raise self._failed(exc) from exc
        finally:
            self._joined.unlink(missing_ok=True)

    def _join(self) -> None:
        """The parts of the hidden file joined into one RRD stream (one manifest) by `rerun rrd route`."""
        import rerun_cli  # the rerun binary rerun-sdk ships beside its Python package

        rerun = Path(rerun_cli.__file__).parent / "rerun"
        cmd = [str(rerun), "rrd", "route", str(self._tmp), "-o", str(self._joined)]
        try:
            done = subprocess.run(cmd, capture_output=True, text=True, timeout=ROUTE_TIMEOUT, check=False)
        except subprocess.TimeoutExpired as exc:
            raise WriteError(f"{self.path}: cannot write the recording: rerun rrd route timed out") from exc
        if done.returncode != 0 or not self._joined.is_file():
            last = (done.stderr.strip().splitlines() or ["no output"])[-1]
            raise WriteError(f"{self.path}: cannot write the recording: rerun rrd route: {last}")

    def _failed(self, exc: OSError) -> WriteError:
        return WriteError(f"{self.path}: cannot write the recording: {exc.strerror or exc}")

    def _drain_loop(self) -> None:
        while not self._stop.wait(DRAIN_EVERY):
            self._write(self._stream.read(flush=False))  # after a failed write: read and dropped (memory bounded)

    def _write(self, data: bytes | None) -> None:
        if self._error is not None:
            return
        view = memoryview(data or b"")
        self._parts += bool(view)
        try:
            while view:
                view = view[os.write(self._fd, view) :]
        except OSError as exc:
            self._error = exc
