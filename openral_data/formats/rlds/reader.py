"""An RLDS / TFDS build folder (``features.json``, ``dataset_info.json``, ``*.tfrecord-NNNNN-of-NNNNN`` shards)
read as an `ArraySource`: one `tf.train.Example` record an episode, read and checked one at a time (bounded by
one record, `tfrecord.MAX_RECORD_BYTES`), its ``steps/...`` lists split into steps on demand."""

from __future__ import annotations

import io
import re
import warnings
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
from PIL import Image, UnidentifiedImageError

from openral_data.errors import DatasetError
from openral_data.formats.episodic import ArrayEpisode, ArraySpec, EpisodeMeta
from openral_data.formats.jsonfile import read_json
from openral_data.formats.rlds.features import Leaf, leaves
from openral_data.formats.rlds.tfrecord import parse_example, records

_SHARD = re.compile(r"^(?P<name>.+?)-(?P<split>[^-]+)\.tfrecord(-\d{5}-of-\d{5})?$")
LANGUAGE = "steps/language_instruction"
# a picture is decoded only when its header says at most this wide and high and this many pixels (a features.json
# `[-1, -1, 3]` bounds nothing; 8192x4096 RGB is 96 MiB)
MAX_PICTURE_SIDE = 8192
MAX_PICTURE_PIXELS = 1 << 25


def detect(path: Path) -> RldsSource | None:
    """The RLDS episodes at `path` if it is a TFDS build folder (it holds ``features.json``), or a dataset folder
    holding exactly one such version folder (``<data_dir>/<name>/`` -> ``<name>/1.0.0/``), else None."""
    if not path.is_dir():
        return None
    if (path / "features.json").is_file():
        return RldsSource(path)
    versions = [d for d in sorted(path.iterdir()) if d.is_dir() and (d / "features.json").is_file()]
    return RldsSource(versions[0]) if len(versions) == 1 else None


class RldsSource:
    """The episodes of every shard of a TFDS build folder, split after split (`<name>-<split>.tfrecord-*`: each
    split's shards in name order), each episode's `meta.split` its split."""

    def __init__(self, path: Path, shards: list[Path] | None = None) -> None:
        """`shards`: only these of the folder's shards (a block of `convert --workers`), else all of them."""
        self._path = path
        features = path / "features.json"
        self._leaves = leaves(read_json(features), features)
        if not any(leaf.per_step for leaf in self._leaves):
            raise DatasetError(f"{features}: steps: no per-step features (not an RLDS dataset)", code="dataset.invalid")
        top = path.resolve()
        self._shards = sorted(
            (p for p in path.iterdir() if _SHARD.match(p.name) and p.is_file() and p.resolve().is_relative_to(top)),
            key=_split_then_name,
        )
        if shards is not None:
            self._shards = [p for p in self._shards if p in shards]
        if not self._shards:
            raise DatasetError(f"{path}: no *.tfrecord-NNNNN-of-NNNNN shards beside features.json",
                               code="dataset.invalid")  # fmt: skip

    @property
    def path(self) -> Path:
        return self._path

    @property
    def layout(self) -> str:
        return "rlds"

    @property
    def fps(self) -> float | None:
        return None  # RLDS stores no step rate; the mapping gives it

    @property
    def shards(self) -> list[Path]:
        return list(self._shards)

    def episodes(self) -> Iterator[ArrayEpisode]:
        counts: dict[str, int] = {}
        for shard in self._shards:
            match = _SHARD.match(shard.name)
            split = match["split"] if match else "train"
            for index, data in enumerate(records(shard)):
                n = counts.get(split, 0)
                counts[split] = n + 1
                episode = RldsEpisode(shard, index, f"{split}/{n}", data, self._leaves)
                episode.meta.split = split
                yield episode

    def close(self) -> None:
        return None


class RldsEpisode:
    """One Example: its per-step keys split into `length` rows, its episode-level keys in `meta.attrs`."""

    def __init__(self, shard: Path, index: int, name: str, data: bytes, all_leaves: list[Leaf]) -> None:
        self._where = f"{shard}: record {index}"
        self._name = name
        features = parse_example(data, self._where)
        self._steps = {leaf.spec.key: leaf for leaf in all_leaves if leaf.per_step}
        self._values = {leaf.spec.key: self._values_of(features, leaf) for leaf in all_leaves}
        self._length = self._check_lengths()
        self._meta = self._episode_meta(all_leaves)

    @property
    def name(self) -> str:
        return self._name

    @property
    def length(self) -> int:
        return self._length

    @property
    def meta(self) -> EpisodeMeta:
        return self._meta

    def specs(self) -> list[ArraySpec]:
        return [leaf.spec for leaf in self._steps.values()]

    def read(self, key: str, start: int, stop: int) -> npt.NDArray[Any]:
        leaf = self._steps.get(key)
        if leaf is None:
            raise DatasetError(f"{self._where}: {key}: no such per-step feature", code="dataset.invalid")
        if not 0 <= start <= stop <= self._length:
            raise ValueError(f"rows {start}:{stop} outside episode {self._name} of {self._length} steps")
        values = self._values[key]
        spec = leaf.spec
        if spec.encoding in ("jpeg", "png"):
            pictures = [_decode(values[i], spec, f"{self._where}: {key}: step {i}") for i in range(start, stop)]
            return np.stack(pictures) if pictures else np.zeros((0, *_known(spec.shape)), np.uint8)
        if spec.dtype == "bytes":
            return np.array(values[start:stop], dtype=object)
        rows: npt.NDArray[Any] = values[start:stop]
        return rows

    def _values_of(self, features: dict[str, Any], leaf: Leaf) -> Any:
        """A key's values: a list of bytes, or a numpy array of its dtype with one row a step (per-step keys)."""
        key = leaf.spec.key
        feature = features.get(key)
        if feature is None:
            raise DatasetError(f"{self._where}: {key}: missing from the episode", code="dataset.invalid")
        kind = feature.WhichOneof("kind")
        if kind != leaf.proto_list:
            raise DatasetError(f"{self._where}: {key}: stored as {kind}, features.json says {leaf.proto_list}",
                               code="dataset.invalid")  # fmt: skip
        raw = getattr(feature, kind).value
        if kind == "bytes_list":
            return list(raw)
        values = np.asarray(raw, dtype=np.float32 if kind == "float_list" else np.int64)
        width = int(np.prod(leaf.spec.shape, dtype=np.int64))
        if width == 0 or len(values) % width:
            raise DatasetError(f"{self._where}: {key}: {len(values)} values do not make rows of shape "
                               f"{list(leaf.spec.shape)}", code="dataset.invalid")  # fmt: skip
        return values.astype(leaf.spec.dtype).reshape(-1, *leaf.spec.shape)

    def _check_lengths(self) -> int:
        lengths = {key: len(self._values[key]) for key in self._steps}
        length = next(iter(lengths.values()))
        for key, n in lengths.items():
            if n != length:
                first = next(iter(lengths))
                raise DatasetError(f"{self._where}: {key}: {n} steps, but {first} has {length} (ragged steps)",
                                   code="dataset.invalid")  # fmt: skip
        return length

    def _episode_meta(self, all_leaves: list[Leaf]) -> EpisodeMeta:
        attrs: dict[str, Any] = {}
        for leaf in all_leaves:
            if leaf.per_step:
                continue
            values = self._values[leaf.spec.key]
            items = [_text(v) if isinstance(v, bytes) else v.tolist() for v in values]
            attrs[leaf.spec.key] = items[0] if len(items) == 1 else items
        language = self._values.get(LANGUAGE) if LANGUAGE in self._steps else None
        text = _text(language[0]) if language else None
        return EpisodeMeta(language=text or None, attrs=attrs)


def _split_then_name(shard: Path) -> tuple[str, str]:
    match = _SHARD.match(shard.name)
    return (match["split"] if match else "", shard.name)


def _text(data: bytes) -> str:
    return data.decode("utf-8", errors="replace")


def _known(shape: tuple[int, ...]) -> tuple[int, ...]:
    return tuple(max(d, 0) for d in shape)


def _decode(data: bytes, spec: ArraySpec, where: str) -> npt.NDArray[np.uint8]:
    """One encoded picture as HxWxC uint8 (C from the declared shape, 3 when it says none), its size (from the
    PNG/JPEG header: `Image.open` reads no pixels) checked against the declared shape and the caps before the
    pixels are decoded."""
    channels = spec.shape[2] if len(spec.shape) == 3 and spec.shape[2] > 0 else 3
    mode = {1: "L", 3: "RGB", 4: "RGBA"}.get(channels)
    if mode is None:
        raise DatasetError(f"{where}: {channels}-channel pictures are not read", code="dataset.unsupported")
    try:
        with warnings.catch_warnings():  # a size over PIL's bomb warning is refused below, not warned about
            warnings.simplefilter("ignore", Image.DecompressionBombWarning)
            img = Image.open(io.BytesIO(data))
        with img:
            width, height = img.size
            want = spec.shape[:2]
            if len(want) == 2 and any(w not in (-1, got) for w, got in zip(want, (height, width), strict=True)):
                raise DatasetError(f"{where}: a {height}x{width} picture, features.json says {want[0]}x{want[1]}",
                                   code="dataset.invalid")  # fmt: skip
            _check_size(height, width, where)
            pixels = np.asarray(img.convert(mode), dtype=np.uint8)
    except (UnidentifiedImageError, OSError, ValueError, Image.DecompressionBombError) as exc:
        raise DatasetError(f"{where}: cannot decode picture: {exc}", code="dataset.invalid") from None
    return pixels.reshape(height, width, channels)


def _check_size(height: int, width: int, where: str) -> None:
    if max(height, width) > MAX_PICTURE_SIDE or height * width > MAX_PICTURE_PIXELS:
        raise DatasetError(f"{where}: a {height}x{width} picture, over the {MAX_PICTURE_SIDE}-pixel side or "
                           f"{MAX_PICTURE_PIXELS}-pixel limit", code="dataset.source.shape")  # fmt: skip
