"""Reading HDF5 files of untrusted origin with h5py, shared by the layouts: opening a file (`open_file`: a
regular file, an unreadable or truncated one a one-line `DatasetError`), a group's member (`member`), per-step
datasets checked before they are read (`step_spec`: numbers or encoded pictures only, a bounded size per step)
and rows read and decoded in bounded chunks (`read_rows`)."""

from __future__ import annotations

import io
import re
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import h5py
import numpy as np
import numpy.typing as npt

from openral_data.errors import DatasetError
from openral_data.formats.episodic import ArraySpec, Encoding
from openral_data.formats.hdf5.contained import check_contained
from openral_data.formats.jsonfile import parse_field

HDF5_SIGNATURE = b"\x89HDF\r\n\x1a\n"
HDF5_SUFFIXES = (".hdf5", ".h5", ".he5", ".hdf")
MAX_STEP_BYTES = 64 * 1024 * 1024  # one step of one array, decoded (a 4K RGB picture is 25 MB)
MAX_STEPS = 100_000_000  # rows of one episode
MAX_ATTR_BYTES = 16 * 1024 * 1024  # a JSON attribute (env_args, problem_info)
NUMERIC_KINDS = "biuf"  # bool, signed, unsigned, float


def is_hdf5(path: Path) -> bool:
    """A regular file that starts with the HDF5 signature (or a folder name ending in an HDF5 suffix: False)."""
    if not path.is_file():
        return False
    try:
        with path.open("rb") as fh:
            return fh.read(8) == HDF5_SIGNATURE
    except OSError:
        return False


def open_file(path: Path) -> h5py.File:
    """`path` opened read-only; a file h5py cannot open (truncated, not HDF5, unreadable) or one that reads
    outside itself (external links, external storage, virtual datasets: `contained`) is one line."""
    if not path.is_file() or (path.is_symlink() and not path.resolve().is_file()):
        raise DatasetError(f"{path}: not a regular file", code="dataset.source.invalid")
    try:
        f = h5py.File(path, "r")
    except (OSError, ValueError) as exc:
        raise DatasetError(f"{path}: cannot open HDF5: {_reason(exc)}", code="dataset.source.invalid") from None
    try:
        check_contained(f, path)  # before anything is read: nothing outside the file
    except BaseException:
        f.close()
        raise
    return f


def _reason(exc: BaseException) -> str:
    text = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
    return text[:300]


def natural_key(name: str) -> tuple[Any, ...]:
    """`demo_2` before `demo_10`: digits compared as numbers."""
    return tuple(int(p) if p.isdigit() else p for p in re.split(r"(\d+)", name))


def member(group: h5py.Group, key: str, file: Path) -> Any:
    """`group[key]` (a dataset or group); a missing key or one that cannot be read is one line naming it."""
    try:
        return group[key]
    except KeyError:
        raise DatasetError(
            f"{file}: {_join(group.name, key)}: missing (here: {', '.join(sorted(group.keys())) or '-'})",
            code="dataset.source.key",
        ) from None
    except (OSError, ValueError, RuntimeError) as exc:
        raise DatasetError(
            f"{file}: {_join(group.name, key)}: cannot read: {_reason(exc)}", code="dataset.source.read"
        ) from None


def rows_of(group: h5py.Group, key: str, file: Path) -> int:
    """The row count of the dataset `group[key]` (what an episode's length is read from); one line when it is
    missing or not an array of rows."""
    ds = member(group, key, file)
    if not isinstance(ds, h5py.Dataset) or not ds.shape:
        raise DatasetError(f"{file}: {_join(group.name, key)}: not an array of rows", code="dataset.source.shape")
    return int(ds.shape[0])


def _join(parent: str, key: str) -> str:
    return f"{parent.rstrip('/')}/{key}".lstrip("/") or "/"


def json_attr(obj: h5py.Group, name: str, file: Path) -> Any:
    """A JSON string attribute parsed (None when absent); bad JSON or an oversized one is one line."""
    if name not in obj.attrs:
        return None
    where = f"{file}: {_join(obj.name, '')}attrs.{name}"
    try:
        raw = obj.attrs[name]
    except (OSError, ValueError, TypeError) as exc:
        raise DatasetError(f"{where}: cannot read: {_reason(exc)}", code="dataset.source.read") from None
    if isinstance(raw, np.ndarray) and raw.shape == ():
        raw = raw.item()
    if isinstance(raw, bytes):
        raw = raw.decode("utf-8", "replace")
    if not isinstance(raw, str) or len(raw) > MAX_ATTR_BYTES:
        raise DatasetError(f"{where}: not a JSON string", code="dataset.source.invalid")
    return parse_field(raw, where)


def attr_scalar(obj: h5py.Group, name: str) -> Any:
    """A scalar attribute as a Python value (None when absent or not a scalar)."""
    try:
        raw = obj.attrs.get(name)
    except (OSError, ValueError, TypeError):
        return None
    if isinstance(raw, np.ndarray):
        return raw.item() if raw.size == 1 else None
    return raw.item() if isinstance(raw, np.generic) else raw


def step_spec(ds: h5py.Dataset, key: str, length: int, file: Path, encoding: Encoding = "raw") -> ArraySpec:
    """The spec of a per-step dataset (`length` rows): numbers, vlen/fixed bytes holding one encoded picture per
    row (its first row decoded for the picture's shape), or `encoding` jpeg/png for padded uint8 rows. Anything
    else (strings, compound types, a row too large, a row count that is not the episode's) is one line."""
    where = f"{file}: {ds.name.lstrip('/')}"
    shape = tuple(int(n) for n in ds.shape)
    if not shape:
        raise DatasetError(f"{where}: a scalar, not one row per step", code="dataset.source.shape")
    if shape[0] != length:
        raise DatasetError(
            f"{where}: {shape[0]} rows, the episode has {length} steps (ragged)", code="dataset.source.shape"
        )
    kind = ds.dtype.kind
    if kind in "SO" or h5py.check_vlen_dtype(ds.dtype) in (bytes, str) or encoding != "raw":
        if length == 0:
            raise DatasetError(f"{where}: no rows", code="dataset.source.shape")
        first = read_rows(ds, 0, 1, file, _sniff(ds, where) if encoding == "raw" else encoding, None)
        return ArraySpec(
            key, "uint8", tuple(int(n) for n in first.shape[1:]), _sniff(ds, where) if encoding == "raw" else encoding
        )
    if kind not in NUMERIC_KINDS or ds.dtype.fields is not None:
        raise DatasetError(f"{where}: dtype {ds.dtype} is not numeric", code="dataset.source.dtype")
    step = int(np.prod(shape[1:], dtype=np.int64)) * ds.dtype.itemsize
    if step > MAX_STEP_BYTES or length > MAX_STEPS:
        raise DatasetError(f"{where}: declared shape {shape} is too large (over {MAX_STEP_BYTES} bytes a step)",
                           code="dataset.source.shape")  # fmt: skip
    return ArraySpec(key, ds.dtype.name, shape[1:], "raw")


def episode_specs(
    items: Iterator[tuple[str, h5py.Dataset, Encoding]], length: int, file: Path
) -> tuple[dict[str, ArraySpec], dict[str, str]]:
    """The per-step arrays of an episode of `length` steps (key -> spec) and the datasets that are not (key -> why:
    a row count that is not the episode's, strings, a row too large...): those are left out, not refused, so a
    log the mapping never asks for (robosuite 1.4's `controller_info/*`) does not block the file."""
    specs: dict[str, ArraySpec] = {}
    ignored: dict[str, str] = {}
    for key, ds, encoding in items:
        try:
            specs[key] = step_spec(ds, key, length, file, encoding)
        except DatasetError as exc:
            ignored[key] = str(exc).removeprefix(f"{file}: {ds.name.lstrip('/')}: ")
    return specs, ignored


def _sniff(ds: h5py.Dataset, where: str) -> Encoding:
    """jpeg or png, from the first row's magic bytes."""
    try:
        head = ds[0]
    except (OSError, ValueError, RuntimeError) as exc:
        raise DatasetError(f"{where}: cannot read: {_reason(exc)}", code="dataset.source.read") from None
    data = (
        head.tobytes() if isinstance(head, np.ndarray) else bytes(head) if isinstance(head, (bytes, bytearray)) else b""
    )
    if data[:3] == b"\xff\xd8\xff":
        return "jpeg"
    if data[:8] == b"\x89PNG\r\n\x1a\n":
        return "png"
    raise DatasetError(f"{where}: bytes that are neither a JPEG nor a PNG picture", code="dataset.source.dtype")


def read_rows(
    ds: h5py.Dataset, start: int, stop: int, file: Path, encoding: Encoding, spec: ArraySpec | None
) -> npt.NDArray[Any]:
    """Rows `start:stop` of `ds`, pictures decoded to HxWxC uint8 (checked against `spec`'s shape)."""
    where = f"{file}: {ds.name.lstrip('/')}"
    try:
        rows = ds[start:stop]
    except (OSError, ValueError, RuntimeError, TypeError) as exc:
        raise DatasetError(
            f"{where}: cannot read rows {start}:{stop}: {_reason(exc)}", code="dataset.source.read"
        ) from None
    if encoding == "raw":
        return np.asarray(rows)
    out = [_decode(row, where, start + i) for i, row in enumerate(rows)]
    for i, img in enumerate(out):
        if spec is not None and img.shape != spec.shape:
            raise DatasetError(f"{where}: step {start + i}: picture of shape {img.shape}, not {spec.shape}",
                               code="dataset.source.shape")  # fmt: skip
    return np.stack(out) if out else np.zeros((0, *(spec.shape if spec else ())), np.uint8)


def _decode(row: Any, where: str, step: int) -> npt.NDArray[np.uint8]:
    """One encoded picture (bytes, or a zero-padded uint8 row: the padding after the image's end is ignored)."""
    from PIL import Image, UnidentifiedImageError

    data = row.tobytes() if isinstance(row, np.ndarray) else bytes(row)
    try:
        with Image.open(io.BytesIO(data)) as img:
            if img.width * img.height * 4 > MAX_STEP_BYTES:
                raise DatasetError(f"{where}: step {step}: picture of {img.width}x{img.height} is too large",
                                   code="dataset.source.shape")  # fmt: skip
            return np.asarray(img.convert("RGB"))
    except (OSError, ValueError, UnidentifiedImageError, Image.DecompressionBombError) as exc:
        raise DatasetError(f"{where}: step {step}: picture does not decode: {_reason(exc)}",
                           code="dataset.source.image") from None  # fmt: skip


def walk_datasets(
    group: h5py.Group, file: Path, skip: tuple[str, ...], prefix: str = ""
) -> Iterator[tuple[str, h5py.Dataset]]:
    """Every dataset under `group` as (slash path relative to it, dataset), in key order; top-level members
    named in `skip` are left out."""
    for key in sorted(group.keys()):
        if not prefix and key in skip:
            continue
        item = member(group, key, file)
        if isinstance(item, h5py.Group):
            yield from walk_datasets(item, file, skip, f"{prefix}{key}/")
        elif isinstance(item, h5py.Dataset):
            yield f"{prefix}{key}", item


def read_key(
    group: h5py.Group, specs: dict[str, ArraySpec], key: str, start: int, stop: int, file: Path,
    ignored: dict[str, str] | None = None,
) -> npt.NDArray[Any]:  # fmt: skip
    """Rows `start:stop` of the per-step array `key` of an episode `group` whose arrays are `specs` (`ignored`:
    its datasets that are not per-step arrays, and why)."""
    ignored = ignored or {}
    spec = specs.get(key)
    if spec is None and key in ignored:
        raise DatasetError(f"{file}: {_join(group.name, key)}: not a per-step array: {ignored[key]}",
                           code="dataset.source.shape")  # fmt: skip
    if spec is None:
        raise DatasetError(
            f"{file}: {_join(group.name, key)}: missing (per-step arrays here: {', '.join(specs) or '-'})",
            code="dataset.source.key",
        )
    return read_rows(member(group, key, file), start, stop, file, spec.encoding, spec)
