"""The chunk files a read of a replay buffer touches, checked before zarr opens or decodes them (`ChunkGuard`):
each a regular file (a FIFO or a device is never opened: it would hang the read) of at most `MAX_CHUNK_BYTES`,
whose compressed data expands to no more than the chunk the array declares. A zstd frame's header, a Blosc or
LZ4 header are read for the size they claim (the decoders allocate it whole); zstd, gzip, zlib, bz2 and lzma
data are decompressed in pieces (thrown away) one byte past that bound at most. Codecs of other kinds (image
codecs) are left to their decoders."""

from __future__ import annotations

import bz2
import itertools
import lzma
import math
import os
import stat
import zipfile
import zlib
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
from backports import zstd

from openral_data.errors import DatasetError
from openral_data.formats.chunk_bounds import expanded_size

MAX_CHUNK_BYTES = 512 * 1024 * 1024  # a chunk, compressed or decompressed (the global cap)
_PIECE = 1 << 20  # decompressed at a time, and dropped


class ChunkGuard:
    """The store at `root` (a folder, or a zip file whose members `_check_zip` bounded) whose chunks are checked."""

    def __init__(self, root: Path) -> None:
        self.root = root
        self._zip = zipfile.ZipFile(root) if root.is_file() else None

    def close(self) -> None:
        if self._zip is not None:
            self._zip.close()
            self._zip = None

    def check(self, array: Any, key: str, start: int, stop: int) -> None:
        """Every chunk of `array` (the store's `key`) holding rows `start:stop`, checked (one line if not)."""
        meta = array.metadata
        declared = np.dtype(array.dtype).itemsize * math.prod(int(c) for c in array.chunks)
        codec = _codec(meta)
        for coords in _chunks(tuple(array.shape), tuple(array.chunks), start, stop):
            rel = f"{array.store_path.path}/{meta.encode_chunk_key(coords)}"
            data = self._read(rel, key)
            if data is not None and codec is not None:
                _check_expansion(codec, data, min(declared, MAX_CHUNK_BYTES), f"{self.root}: {rel}")

    def _read(self, rel: str, key: str) -> bytes | None:
        """The chunk file's bytes (None: absent, the fill value), refused unless a bounded regular file."""
        where = f"{self.root}: {rel}"
        if self.root.is_file():  # a zip store (reopened when read after `close`, as zarr's ZipStore reopens)
            if self._zip is None:
                self._zip = zipfile.ZipFile(self.root)
            try:
                return self._zip.read(rel)
            except KeyError:
                return None
        path = self.root / rel
        try:
            st = os.stat(path)
        except FileNotFoundError:
            return None
        except OSError as exc:
            raise DatasetError(f"{where}: cannot read the chunk: {exc.strerror}", code="dataset.invalid") from None
        if not stat.S_ISREG(st.st_mode):
            raise DatasetError(f"{where}: the chunk is not a regular file", code="dataset.unsafe")
        if st.st_size > MAX_CHUNK_BYTES:
            raise DatasetError(f"{where}: a chunk of {st.st_size} bytes (limit {MAX_CHUNK_BYTES})",
                               code="dataset.invalid")  # fmt: skip
        with open(path, "rb") as fh:
            return fh.read(MAX_CHUNK_BYTES + 1)


def _chunks(shape: tuple[int, ...], chunks: tuple[int, ...], start: int, stop: int) -> Iterator[tuple[int, ...]]:
    """The chunk coordinates rows `start:stop` touch (every chunk of the other axes)."""
    if stop <= start or not shape:
        return
    first = range(start // chunks[0], (stop - 1) // chunks[0] + 1)
    rest = [range(math.ceil(n / c)) for n, c in zip(shape[1:], chunks[1:], strict=True)]
    yield from itertools.product(first, *rest)


def _codec(meta: Any) -> str | None:
    """The compressor's name (zarr v2 `compressor`, or v3's bytes-to-bytes codec); None: nothing to check."""
    if int(getattr(meta, "zarr_format", 3)) == 2:
        compressor = getattr(meta, "compressor", None)
        return None if compressor is None else str(compressor.codec_id)
    for codec in getattr(meta, "codecs", ()):
        name = type(codec).__name__.lower().removesuffix("codec")
        if name in _STREAMS or name in ("blosc", "lz4"):
            return name
    return None


class _Zlib:
    """zlib's decompressor (gzip or zlib, from the header) with the streaming interface `expanded_size` takes."""

    def __init__(self) -> None:
        self._d = zlib.decompressobj(wbits=47)

    @property
    def eof(self) -> bool:
        return self._d.eof

    @property
    def needs_input(self) -> bool:
        return not self._d.unconsumed_tail

    @property
    def unused_data(self) -> bytes:
        return self._d.unused_data

    def decompress(self, data: bytes, max_length: int = -1) -> bytes:
        return self._d.decompress(self._d.unconsumed_tail + data, max(max_length, 0))


_STREAMS: dict[str, Callable[[], Any]] = {
    "zstd": zstd.ZstdDecompressor,
    "gzip": _Zlib,
    "zlib": _Zlib,
    "bz2": bz2.BZ2Decompressor,
    "lzma": lzma.LZMADecompressor,
}


def _check_expansion(codec: str, data: bytes, limit: int, where: str) -> None:
    """`data` (compressed with `codec`) expands to at most `limit` bytes, by its header and by decompressing."""
    claimed: int | None = None
    if codec == "blosc" and len(data) >= 16:
        claimed = int.from_bytes(data[4:8], "little")
    elif codec == "lz4" and len(data) >= 4:
        claimed = int.from_bytes(data[:4], "little")
    elif codec == "zstd":
        try:
            claimed = zstd.get_frame_info(data).decompressed_size
        except zstd.ZstdError:
            claimed = None  # the decoder says what is wrong with it
    if claimed is not None and claimed > limit:
        raise _refused(where, f"a {codec} chunk claiming {claimed} bytes, more than the {limit} its array declares")
    make = _STREAMS.get(codec)
    if make is None:
        return
    try:
        size = expanded_size(make, data, limit + 1)
    except (zstd.ZstdError, zlib.error, OSError, EOFError, ValueError, lzma.LZMAError) as exc:
        raise _refused(where, f"a {codec} chunk that does not decompress: {exc}") from None
    if size > limit:
        raise _refused(where, f"a {codec} chunk expanding past the {limit} bytes its array declares")


def _refused(where: str, what: str) -> DatasetError:
    return DatasetError(f"{where}: {what}", code="dataset.invalid")
