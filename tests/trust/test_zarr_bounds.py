"""Class 4 of #49, Zarr chunks read bounded: a 100-byte zstd chunk whose frame header claims 1 TB, a 3 GB zstd
or gzip chunk bomb and a chunk that is a FIFO are each one line naming the chunk, under a memory limit and a
timeout (before: a MemoryError traceback, or a hang)."""

from __future__ import annotations

import gzip
from collections.abc import Callable
from pathlib import Path

import pytest
from backports import zstd

from tests.support.bounded import run_bounded
from tests.support.replay_buffer import replace_chunk, sample_episodes, write_replay_buffer

MB = 1 << 20
BOMB = 3 << 30  # what the bombs expand to


def _zstd_claiming(size: int) -> bytes:
    """One zstd frame whose header says `size` bytes of content (single segment, 8-byte size), then one raw
    block of 64 bytes: the whole chunk is about 80 bytes."""
    header = b"\x28\xb5\x2f\xfd" + bytes([0xE0]) + size.to_bytes(8, "little")
    block = (1 | (64 << 3)).to_bytes(3, "little") + b"\x00" * 64
    return header + block


def _zstd_bomb() -> bytes:
    """One zstd frame (no size in its header) of `BOMB` zero bytes."""
    comp = zstd.ZstdCompressor(level=1)
    zeros = bytes(16 * MB)
    parts = [comp.compress(zeros) for _ in range(BOMB // len(zeros))]
    return b"".join(parts) + comp.flush()


def _gzip_bomb() -> bytes:
    """`BOMB` zero bytes as gzip members of 64 MB each, one after the other (gzip reads them all)."""
    member = gzip.compress(bytes(64 * MB), compresslevel=1)
    return member * (BOMB // (64 * MB))


def _store(root: Path, compressor: dict[str, object], chunk: bytes | None) -> Path:
    """A replay buffer whose data/action says `compressor` and whose chunk 0.0 is `chunk` (None: a FIFO)."""
    return replace_chunk(write_replay_buffer(root / "b.zarr", sample_episodes()), compressor, chunk)


CASES: dict[str, tuple[dict[str, object], Callable[[], bytes | None], str]] = {
    "zstd-claims-1tb": ({"id": "zstd", "level": 1}, lambda: _zstd_claiming(1 << 40), "claiming 1099511627776 bytes"),
    "zstd-3gb-bomb": ({"id": "zstd", "level": 1}, _zstd_bomb, "expanding past the 32 bytes"),
    "gzip-3gb-bomb": ({"id": "gzip", "level": 1}, _gzip_bomb, "expanding past the 32 bytes"),
    "fifo-chunk": ({"id": "zstd", "level": 1}, lambda: None, "not a regular file"),
}


@pytest.mark.parametrize("name", list(CASES))
def test_a_zarr_chunk_is_read_bounded(name: str, tmp_path: Path) -> None:
    compressor, make, says = CASES[name]
    store = _store(tmp_path, compressor, make())
    out = tmp_path / "out"
    run = run_bounded("convert", str(store), str(out), "--fps", "10", "--codec", "h264", timeout=90)
    assert not run.timed_out, "hung"
    lines = [ln for ln in run.stderr.splitlines() if ln.strip()]
    assert "Traceback" not in run.stderr and "MemoryError" not in run.stderr, run.stderr[-2000:]
    assert run.returncode == 2 and len(lines) == 1, (run.returncode, run.stderr[-2000:])
    assert lines[0].startswith(f"error: {store}: data/action/0.0: ") and says in lines[0], lines[0]
