"""Reading a zarr replay buffer as an `ArraySource` (see the package docstring for the layout).

Opening checks the whole layout once, before a row is read: a ``data`` group of numeric arrays, a 1-D integer
``meta/episode_ends`` that rises strictly, every array at least as long as the last end (diffusion policy's own
check), no chunk or step larger than a bound, and every codec available (UMI's JPEG-XL/JPEG image codecs need
`imagecodecs`; without it one line names the codec). Reads then fetch only the chunks a row range touches.
"""

from __future__ import annotations

import os
import stat
import zipfile
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from openral_data.errors import DatasetError
from openral_data.formats.episodic import ArrayEpisode, ArraySpec, EpisodeMeta
from openral_data.formats.zarr_replay.chunks import MAX_CHUNK_BYTES, ChunkGuard

# a chunk (decompressed) or one step of one array larger than `MAX_CHUNK_BYTES` is refused before anything is
# read: a reader holds at most one chunk per array it reads, so memory stays bounded by what the file declares,
# and each chunk file is checked (`chunks.ChunkGuard`: regular, expanding to no more than declared) before zarr
# reads it
# meta/episode_ends is read whole at open (8 bytes an episode)
MAX_EPISODES = 10_000_000
# what zarr and numcodecs raise on a damaged store, chunk or metadata document
_ZARR_ERRORS = (OSError, ValueError, KeyError, TypeError, RuntimeError, zipfile.BadZipFile)


def detect(path: Path) -> ZarrReplaySource | None:
    """The replay buffer at `path` if it is a zarr store (a folder with ``.zgroup``/``zarr.json``, or a
    ``*.zarr.zip``), else None. A zarr store that is not a valid replay buffer raises `DatasetError`."""
    if path.is_dir() and ((path / ".zgroup").is_file() or (path / "zarr.json").is_file()):
        return ZarrReplaySource(path)
    if path.is_file() and path.name.endswith(".zarr.zip"):
        return ZarrReplaySource(path)
    return None


def register_image_codecs() -> None:
    """imagecodecs' numcodecs codecs (UMI's ``imagecodecs_jpegxl``, ``imagecodecs_jpeg``, ...) registered, when
    imagecodecs is installed (as UMI itself does before it opens a buffer); without it those stores are refused in
    one line naming the codec."""
    try:
        from imagecodecs.numcodecs import register_codecs
    except ImportError:
        return
    register_codecs(verbose=False)


def _bad(path: Path, key: str, what: str) -> DatasetError:
    return DatasetError(f"{path}: {key}: {what}", code="dataset.invalid")


@dataclass(frozen=True)
class _Array:
    key: str  # data/<name>
    array: Any  # zarr.Array
    spec: ArraySpec
    guard: ChunkGuard  # its chunk files checked before a read


class ZarrReplaySource:
    """A diffusion policy / UMI replay buffer; episodes are row ranges of the shared ``data/*`` arrays."""

    def __init__(self, path: Path) -> None:
        import zarr

        register_image_codecs()
        self._path = path
        self._zip: Any = None
        self._guard: ChunkGuard | None = None
        try:
            if path.is_file():
                _check_zip(path)
                self._zip = zarr.storage.ZipStore(path, mode="r")
                root = zarr.open_group(self._zip, mode="r")
            else:
                _check_links(path)
                root = zarr.open_group(str(path), mode="r")
            self._guard = ChunkGuard(path)
            self._arrays = _open_arrays(path, root, self._guard)
            self._ends = _episode_ends(path, root, self._arrays, self._guard)
        except BaseException:
            self.close()
            raise

    @property
    def path(self) -> Path:
        return self._path

    @property
    def layout(self) -> str:
        return "zarr"

    @property
    def fps(self) -> float | None:
        return None  # replay buffers store no rate (diffusion policy's configs and UMI's docs give it)

    def episodes(self) -> Iterator[ArrayEpisode]:
        start = 0
        for i, end in enumerate(self._ends):
            yield ZarrEpisode(self._path, str(i), start, int(end), self._arrays)
            start = int(end)

    def close(self) -> None:
        if self._zip is not None:
            self._zip.close()
            self._zip = None
        if self._guard is not None:
            self._guard.close()
            self._guard = None


class ZarrEpisode:
    """Rows ``start:stop`` of every ``data/*`` array."""

    def __init__(self, path: Path, name: str, start: int, stop: int, arrays: dict[str, _Array]) -> None:
        self._path = path
        self._name = name
        self._start = start
        self._stop = stop
        self._arrays = arrays

    @property
    def name(self) -> str:
        return self._name

    @property
    def length(self) -> int:
        return self._stop - self._start

    @property
    def meta(self) -> EpisodeMeta:
        return EpisodeMeta()

    def specs(self) -> list[ArraySpec]:
        return [a.spec for a in self._arrays.values()]

    def read(self, key: str, start: int, stop: int) -> npt.NDArray[Any]:
        entry = self._arrays.get(key)
        if entry is None:
            raise _bad(self._path, key, f"no such array (arrays: {', '.join(self._arrays) or '-'})")
        if not 0 <= start <= stop <= self.length:
            raise ValueError(f"rows {start}:{stop} outside episode {self._name} of {self.length} steps")
        entry.guard.check(entry.array, key, self._start + start, self._start + stop)
        try:
            rows: npt.NDArray[Any] = np.asarray(entry.array[self._start + start : self._start + stop])
        except _ZARR_ERRORS as exc:
            raise _bad(self._path, key, f"cannot read rows of episode {self._name}: {_first_line(exc)}") from None
        return rows


def _first_line(exc: BaseException) -> str:
    text = str(exc).strip()
    return (text.splitlines()[0] if text else type(exc).__name__).split(". Register one")[0]


def _check_zip(path: Path) -> None:
    """A zip store whose members all fit the chunk bound (a zip member is read whole)."""
    try:
        with zipfile.ZipFile(path) as zf:
            for info in zf.infolist():
                if info.file_size > MAX_CHUNK_BYTES:
                    raise _bad(path, info.filename, f"zip member of {info.file_size} bytes (limit {MAX_CHUNK_BYTES})")
    except (OSError, zipfile.BadZipFile) as exc:
        raise _bad(path, "zip", f"not a readable zip store: {_first_line(exc)}") from None


def _check_links(root: Path) -> None:
    """No entry of a directory store is a symlink that leads outside it (zarr would follow it), nor a FIFO,
    socket or device (zarr would open it and wait)."""
    top = root.resolve()
    for folder, dirs, files in os.walk(root):
        for name in [*dirs, *files]:
            entry = Path(folder) / name
            mode = entry.lstat().st_mode
            if stat.S_ISLNK(mode) and not entry.resolve().is_relative_to(top):
                rel = entry.relative_to(root)
                raise DatasetError(f"{root}: {rel}: symlink leads outside the store", code="dataset.unsafe")
            if not (stat.S_ISLNK(mode) or stat.S_ISDIR(mode) or stat.S_ISREG(mode)):
                rel = entry.relative_to(root)
                raise DatasetError(f"{root}: {rel}: not a regular file", code="dataset.unsafe")


def _open_arrays(path: Path, root: Any, guard: ChunkGuard) -> dict[str, _Array]:
    """Every array under ``data/`` (nested groups as slash paths), checked: numeric dtype, bounded chunks."""
    import zarr

    try:
        data = root["data"]
    except (*_ZARR_ERRORS, zarr.errors.BaseZarrError):
        raise _bad(path, "data", "missing: a replay buffer keeps its per-step arrays under data/") from None
    if not isinstance(data, zarr.Group):
        raise _bad(path, "data", "is an array, not a group of per-step arrays")
    out: dict[str, _Array] = {}
    try:
        members = sorted(data.members(max_depth=None))
    except zarr.errors.UnknownCodecError as exc:
        hint = "pip install imagecodecs for UMI's images"
        raise DatasetError(f"{path}: data: {_first_line(exc)} ({hint})", code="dataset.unsupported") from None
    except (*_ZARR_ERRORS, zarr.errors.BaseZarrError) as exc:
        raise _bad(path, "data", f"unreadable: {_first_line(exc)}") from None
    for name, node in members:
        if isinstance(node, zarr.Array):
            key = f"data/{name}"
            out[key] = _Array(key, node, _spec(path, key, node), guard)
    if not out:
        raise _bad(path, "data", "holds no arrays")
    return out


def _spec(path: Path, key: str, array: Any) -> ArraySpec:
    dtype = np.dtype(array.dtype)
    if dtype.kind not in "biuf":
        raise _bad(path, key, f"dtype {dtype} is not numeric or bool")
    shape = tuple(int(n) for n in array.shape)
    if not shape:
        raise _bad(path, key, "a 0-d array has no rows (every per-step array has one row a step)")
    step = dtype.itemsize * int(np.prod(shape[1:], dtype=np.int64))
    chunk = dtype.itemsize * int(np.prod([int(c) for c in array.chunks], dtype=np.int64))
    if max(step, chunk) > MAX_CHUNK_BYTES:
        raise _bad(path, key, f"declares {max(step, chunk)} bytes per step or chunk (limit {MAX_CHUNK_BYTES})")
    return ArraySpec(key=key, dtype=dtype.name, shape=shape[1:], encoding="raw")


def _episode_ends(path: Path, root: Any, arrays: dict[str, _Array], guard: ChunkGuard) -> list[int]:
    """meta/episode_ends, checked against every data array (each holds at least its last end's rows)."""
    import zarr

    key = "meta/episode_ends"
    try:
        node = root[key]
    except (*_ZARR_ERRORS, zarr.errors.BaseZarrError):
        raise _bad(path, key, "missing: a replay buffer ends its episodes there") from None
    if not isinstance(node, zarr.Array) or len(node.shape) != 1 or np.dtype(node.dtype).kind not in "iu":
        raise _bad(path, key, "not a 1-D integer array")
    if node.shape[0] > MAX_EPISODES:
        raise _bad(path, key, f"declares {node.shape[0]} episodes (limit {MAX_EPISODES})")
    guard.check(node, key, 0, int(node.shape[0]))
    try:
        ends = [int(e) for e in np.asarray(node[:])]
    except _ZARR_ERRORS as exc:
        raise _bad(path, key, f"unreadable: {_first_line(exc)}") from None
    previous = 0
    for i, end in enumerate(ends):
        if end <= previous:
            raise _bad(path, key, f"entry {i} ({end}) is not above the previous end ({previous})")
        previous = end
    for a in arrays.values():
        if a.array.shape[0] < previous:
            raise _bad(path, a.key, f"{a.array.shape[0]} rows, but meta/episode_ends ends at row {previous}")
    return ends
