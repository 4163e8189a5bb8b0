"""Atomic file replacement: write beside the target, flush to disk, then rename over it.

A `Batch` with a journal makes a group of replacements all-or-nothing across a crash: every file is staged
and fsynced first, then the journal (the list of renames) is made durable, then the renames run and the
journal is removed. A process killed during the renames leaves the journal; `replay_journal` finishes them.
A batch's staged files are fsynced together when it commits, and so are the folders its renames changed
(`fsync_all`): the file system groups concurrent flushes into one journal commit of its own, where one flush
after the other waits for a commit each (an episode's commit holds a dozen files and half as many folders).
"""

from __future__ import annotations

import errno
import json
import os
import stat
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pyarrow as pa
import pyarrow.parquet as pq

from openral_data.errors import DatasetError
from openral_data.formats.jsonfile import parse_json
from openral_data.paths import contained, contained_all

CONTROL_FLAGS = os.O_NOFOLLOW | os.O_NONBLOCK | os.O_CLOEXEC


def open_control(path: Path, flags: int = os.O_RDONLY, mode: int = 0o644) -> int:
    """Open one of our control files (lock, journal, settings, markers) as a file descriptor, safely.

    A dataset is untrusted: the file must be a regular file, not a symlink (``O_NOFOLLOW``), not a FIFO or a
    device (opened ``O_NONBLOCK``, then checked), or the open is refused with one line. A missing file raises
    `FileNotFoundError` as `os.open` does (pass ``os.O_CREAT`` to create it).
    """
    try:
        fd = os.open(path, flags | CONTROL_FLAGS, mode)
    except OSError as exc:
        if exc.errno == errno.ELOOP:
            raise DatasetError(f"{path}: is a symbolic link; refusing to follow it", code="dataset.unsafe") from None
        raise
    if not stat.S_ISREG(os.fstat(fd).st_mode):
        os.close(fd)
        raise DatasetError(f"{path}: not a regular file; refusing to use it", code="dataset.unsafe")
    return fd


def read_control(path: Path, limit: int = 1 << 24) -> bytes:
    """The bytes of a control file opened with `open_control` (at most `limit`; larger is refused)."""
    fd = open_control(path)
    try:
        if os.fstat(fd).st_size > limit:
            raise DatasetError(f"{path}: larger than {limit} bytes; not one of ours", code="dataset.invalid")
        chunks = []
        while chunk := os.read(fd, 1 << 16):
            chunks.append(chunk)
        return b"".join(chunks)
    finally:
        os.close(fd)


def state_dir(root: Path, *sub: str) -> Path:
    """``root/.openral`` (or a folder below it, `sub`), created if missing; refused when it or any folder on
    the way is a symlink or not a folder."""
    path = root / ".openral"
    for name in ("", *sub):
        path = path / name if name else path
        try:
            st = os.lstat(path)
        except FileNotFoundError:
            path.mkdir(parents=True, exist_ok=True)
            st = os.lstat(path)
        if not stat.S_ISDIR(st.st_mode):
            raise DatasetError(
                f"{path}: not a real folder (a symbolic link or a file); refusing to use it", code="dataset.unsafe"
            )
    return path


def fsync_dir(path: Path) -> None:
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def tmp_name(path: Path) -> Path:
    """A sibling name no LeRobot glob (`*.parquet`, `*.mp4`) matches."""
    return path.with_name(f".{path.name}.tmp")


def fsync_file(path: Path) -> None:
    with open(path, "rb+") as fh:
        os.fsync(fh.fileno())


FSYNC_THREADS = 8  # at most this many flushes at once (`fsync_all`)


def fsync_all(paths: Sequence[Path], fsync: Callable[[Path], None]) -> None:
    """`fsync(path)` for every one of `paths`, at once (a thread each, at most FSYNC_THREADS); when they have all
    ended, the first failure (in `paths` order) is raised."""
    if len(paths) <= 1:
        for path in paths:
            fsync(path)
        return
    with ThreadPoolExecutor(max_workers=min(FSYNC_THREADS, len(paths)), thread_name_prefix="fsync") as pool:
        futures = [pool.submit(fsync, path) for path in paths]
    failed = next((exc for exc in (f.exception() for f in futures) if exc is not None), None)
    if failed is not None:
        raise failed


def fsync_tree(root: Path) -> None:
    """fsync every file and folder below `root` (and `root` itself), e.g. before renaming it into place."""
    for dirpath, _, files in os.walk(root):
        for name in files:
            fsync_file(Path(dirpath) / name)
        fsync_dir(Path(dirpath))


def move_into_place(tmp: Path, path: Path, durable: bool = True) -> None:
    """Atomically rename a finished temporary file over `path`."""
    if durable:
        fsync_file(tmp)
    os.replace(tmp, path)
    if durable:
        fsync_dir(path.parent)


def bytes_writer(data: bytes) -> Callable[[Path], None]:
    def write(path: Path) -> None:
        path.write_bytes(data)

    return write


def parquet_writer(table: pa.Table, *, small: bool = False) -> Callable[[Path], None]:
    """A `writer` for `write_with` and `Batch.write_with`: `table` as one snappy-compressed parquet file.

    `small`: for a table of a row or two with many columns (an episode's meta/episodes row until it is joined),
    where per-column overhead is most of the file: no compression, dictionaries or column statistics (about a
    quarter smaller, and cheaper to write). Page checksums stay either way."""

    def write(path: Path) -> None:
        if small:
            pq.write_table(
                table, path, compression="none", use_dictionary=False, write_statistics=False, write_page_checksum=True
            )
        else:
            pq.write_table(table, path, compression="snappy", write_page_checksum=True)

    return write


def concat_parquet_writer(sources: list[Path], schema: pa.Schema) -> Callable[[Path], None]:
    """A `writer` for `write_with`: the row groups of `sources` in order, as they are, in one file of `schema`
    (written like `parquet_writer`; one row group read at a time)."""

    def write(path: Path) -> None:
        with pq.ParquetWriter(path, schema, compression="snappy", write_page_checksum=True) as out:
            for source in sources:
                pf = pq.ParquetFile(source)
                for i in range(pf.num_row_groups):
                    out.write_table(pf.read_row_group(i).cast(schema))

    return write


def write_with(path: Path, writer: Callable[[Path], None], durable: bool = True) -> None:
    """Write `path` through `writer(tmp)`, then atomically replace it; on error the old file stays (and no tmp)."""
    batch = Batch(durable)
    batch.write_with(path, writer)
    try:
        batch.commit()
    finally:
        batch.discard()


def write_bytes(path: Path, data: bytes, durable: bool = True) -> None:
    write_with(path, bytes_writer(data), durable)


class Batch:
    """Several files written beside their targets first, then renamed into place one after the other.

    Preparing every file before the first rename shrinks the moment in which a reader could see some of the
    new files but not the others to a few renames; the renames happen in write order, so the file that makes
    the others count (info.json) is written last and lands last.
    """

    def __init__(self, durable: bool = True, journal: Path | None = None) -> None:
        self.durable = durable
        self.journal = journal
        self._staged: list[tuple[Path, Path]] = []
        self._flushed = 0  # the staged files before this one are fsynced

    def write_with(self, path: Path, writer: Callable[[Path], None]) -> None:
        if any(final == path for _, final in self._staged):
            raise ValueError(f"{path} is already staged in this batch")
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = tmp_name(path)
        _clear_stale(tmp)
        try:
            writer(tmp)
        except BaseException:
            tmp.unlink(missing_ok=True)
            raise
        self._staged.append((tmp, path))

    def flush(self) -> None:
        """fsync the files staged since the last flush, all at once (`fsync_all`); `commit` does this first."""
        if self.durable:
            fsync_all([tmp for tmp, _ in self._staged[self._flushed :]], fsync_file)
        self._flushed = len(self._staged)

    def staged(self) -> list[tuple[Path, Path]]:
        """(staged file, destination) of every file written into this batch so far, in write order."""
        return list(self._staged)

    def commit(self) -> None:
        self.flush()
        journaled = self.write_journal()
        _rename_all(self._staged, self.durable)
        if journaled and self.journal is not None:
            self.journal.unlink()
            if self.durable:
                fsync_dir(self.journal.parent)
        self._staged.clear()
        self._flushed = 0

    def write_journal(self) -> bool:
        """Make the list of pending renames durable (the commit point); False when there is no journal."""
        if self.journal is None or not self._staged:
            return False
        self.flush()  # every staged file durable before the journal names it
        here = self.journal.parent  # paths relative to the journal: a moved dataset still replays
        renames = [(os.path.relpath(tmp, here), os.path.relpath(path, here)) for tmp, path in self._staged]
        check_renames(self.journal, renames)  # what a replay would refuse is never written
        write_bytes(self.journal, json.dumps({"renames": renames}).encode(), self.durable)
        return True

    def discard(self) -> None:
        for tmp, _ in self._staged:
            tmp.unlink(missing_ok=True)
        self._staged.clear()
        self._flushed = 0


def _clear_stale(tmp: Path) -> None:
    """Remove a leftover staged file before writing it anew: a planted symlink there is never written through."""
    try:
        st = os.lstat(tmp)
    except FileNotFoundError:
        return
    if stat.S_ISDIR(st.st_mode):
        raise DatasetError(f"{tmp}: a folder where a staged file goes; refusing to use it", code="dataset.unsafe")
    tmp.unlink()


def _rename_all(renames: list[tuple[Path, Path]], durable: bool) -> None:
    for tmp, path in renames:
        os.replace(tmp, path)
    if durable:
        fsync_all(list(dict.fromkeys(path.parent for _, path in renames)), fsync_dir)


JOURNAL_AREAS = ("meta", "data", "videos", ".openral")  # where a journaled rename may land, below the root


def journal_renames(journal: Path) -> list[tuple[Path, Path]]:
    """The (staged file, destination) pairs of a commit journal, each checked before anything moves.

    The journal is untrusted (a dataset can be crafted): it is read with `read_control` (no symlink, no FIFO);
    every entry, relative to the journal's folder, must resolve inside the dataset root (the folder holding
    ``.openral``) under meta/, data/, videos/ or .openral/, and its staged file must be ``tmp_name`` of its
    destination. Anything else is refused in one line (``dataset.unsafe``).
    """
    try:
        data = parse_json(read_control(journal))
        entries = data["renames"]
        if not isinstance(entries, list) or not all(
            isinstance(e, list) and len(e) == 2 and all(isinstance(p, str) for p in e) for e in entries
        ):
            raise TypeError("renames must be a list of [staged file, destination] pairs")
        pairs = [(str(a), str(b)) for a, b in entries]
    except (ValueError, KeyError, TypeError) as exc:  # a torn journal cannot exist: it lands by rename
        raise DatasetError(f"{journal}: unreadable commit journal: {exc}", code="dataset.invalid") from None
    return check_renames(journal, pairs)


def check_renames(journal: Path, pairs: list[tuple[str, str]]) -> list[tuple[Path, Path]]:
    """`pairs` (relative to the journal's folder) as paths, refused unless each stays inside the dataset."""
    here = journal.parent
    root = here.parent
    try:  # all at once (each folder resolved once); a refusal is then located entry by entry
        paths = contained_all(root, [os.path.relpath(here / p, root) for pair in pairs for p in pair], str(journal))
    except DatasetError:
        paths = []
    out: list[tuple[Path, Path]] = []
    for i, (a, b) in enumerate(pairs):
        source = f"{journal}: renames[{i}]"
        if paths:
            tmp, dest = paths[2 * i], paths[2 * i + 1]
        else:
            dest = contained(root, os.path.relpath(here / b, root), source)
            tmp = contained(root, os.path.relpath(here / a, root), source)
        rel = dest.relative_to(root)
        if len(rel.parts) < 2 or rel.parts[0] not in JOURNAL_AREAS:
            raise DatasetError(
                f"{source}: {b!r} is not inside {', '.join(JOURNAL_AREAS)} of {root}", code="dataset.unsafe"
            )
        if tmp != tmp_name(dest):
            raise DatasetError(f"{source}: {a!r} is not the staged file of {b!r}", code="dataset.unsafe")
        out.append((tmp, dest))
    return out


def replay_journal(journal: Path, durable: bool = True) -> int:
    """Finish the renames of a batch whose commit was interrupted; returns how many files it moved.

    Renames already done have no temporary file left and are skipped, so replaying twice is harmless. Every
    entry is checked (`journal_renames`) before the first rename.
    """
    try:
        os.lstat(journal)
    except FileNotFoundError:
        return 0
    renames = journal_renames(journal)
    pending = [(tmp, path) for tmp, path in renames if os.path.lexists(tmp)]
    _rename_all(pending, durable)
    journal.unlink()
    if durable:
        fsync_dir(journal.parent)
    return len(pending)
