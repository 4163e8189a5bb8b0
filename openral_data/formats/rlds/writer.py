"""An RLDS / TFDS build folder written without TensorFlow: ``features.json`` and ``dataset_info.json`` as a TFDS
builder writes them, and ``<name>-<split>.tfrecord-NNNNN-of-NNNNN`` shards of one `tf.train.Example` an episode
(the framing and message of `tfrecord`), so `tfds.builder_from_directory(OUT)` loads it with no code of ours.

What is written is a list of `Column`s (a step's ``steps/<path>`` or an episode's ``episode_metadata/<path>``),
each a TFDS Tensor / Scalar (plain encoding), Image (JPEG or PNG) or Text; an episode's values are added step
after step (`EpisodeExample`), each step's one after another in its key's list, as TFDS's example serializer does.
"""

from __future__ import annotations

import io
import json
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import numpy as np
import numpy.typing as npt
from PIL import Image

from openral_data.formats.rlds.features import PROTO_LISTS
from openral_data.formats.rlds.tfrecord import framed, serialize_example

_TFDS = "tensorflow_datasets.core.features."
STEPS = "steps"
VERSION = "1.0.0"
ColumnKind = Literal["tensor", "image", "text"]


@dataclass(frozen=True)
class Column:
    """One serialized key: ``steps/observation/state`` (a step's) or ``episode_metadata/episode_index``."""

    key: str
    kind: ColumnKind
    dtype: str = "float32"  # a tensor's TFDS dtype (an image is uint8)
    shape: tuple[int, ...] = ()
    image_format: str = "png"  # an image's encoding: png or jpeg

    @property
    def proto_list(self) -> str:
        return "bytes_list" if self.kind != "tensor" else PROTO_LISTS[self.dtype]

    def doc(self) -> dict[str, Any]:
        """The column's feature as features.json describes it."""
        dims = {"dimensions": [str(d) for d in self.shape]} if self.shape else {}
        if self.kind == "image":
            image = {"shape": dims, "dtype": "uint8", "encodingFormat": self.image_format}
            return {"pythonClassName": _TFDS + "image_feature.Image", "image": image}
        if self.kind == "text":
            return {"pythonClassName": _TFDS + "text_feature.Text", "text": {}}
        cls = "scalar.Scalar" if not self.shape else "tensor_feature.Tensor"
        return {"pythonClassName": _TFDS + cls, "tensor": {"shape": dims, "dtype": self.dtype, "encoding": "none"}}

    def values(self, value: Any) -> list[Any]:
        """One step's (or the episode's) value as the entries it adds to the key's list."""
        if self.kind == "image":
            return [encode_picture(value, self.image_format)]
        if self.kind == "text":
            return [str(value).encode("utf-8")]
        flat = np.asarray(value, dtype=self.dtype).reshape(-1)
        return (flat.astype(np.int64) if self.proto_list == "int64_list" else flat).tolist()


def encode_picture(pixels: npt.NDArray[np.uint8], fmt: str) -> bytes:
    """HxWxC uint8 pixels as PNG (exact) or JPEG (quality 95) bytes."""
    out = io.BytesIO()
    picture = Image.fromarray(pixels[..., 0] if pixels.ndim == 3 and pixels.shape[2] == 1 else pixels)
    if fmt == "jpeg":
        picture.save(out, format="JPEG", quality=95)
    else:
        picture.save(out, format="PNG")
    return out.getvalue()


class EpisodeExample:
    """One episode's Example, built step by step."""

    def __init__(self, columns: Sequence[Column]) -> None:
        self._columns = {c.key: c for c in columns}
        self._lists: dict[str, tuple[str, list[Any]]] = {c.key: (c.proto_list, []) for c in columns}

    def add(self, key: str, value: Any) -> None:
        self._lists[key][1].extend(self._columns[key].values(value))

    def to_bytes(self) -> bytes:
        return serialize_example(self._lists)


def features_doc(columns: Sequence[Column]) -> dict[str, Any]:
    """features.json of `columns`: the ``steps`` keys as a TFDS Dataset of a FeaturesDict, every other top-level
    name a FeaturesDict (``episode_metadata``)."""
    tree: dict[str, Any] = {}
    for column in columns:
        *parents, leaf = column.key.split("/")
        node = tree
        for name in parents:
            node = node.setdefault(name, {})
        node[leaf] = column.doc()
    top = {name: _dict_doc(node) for name, node in tree.items()}
    if STEPS in top:
        top[STEPS] = {"pythonClassName": _TFDS + "dataset_feature.Dataset",
                      "sequence": {"feature": top[STEPS], "length": "-1"}}  # fmt: skip
    return _dict_doc_of(top)


def _dict_doc(node: dict[str, Any]) -> dict[str, Any]:
    """A tree of column docs as nested FeaturesDicts (a leaf is a doc: it has a pythonClassName)."""
    if "pythonClassName" in node:
        return node
    return _dict_doc_of({name: _dict_doc(child) for name, child in sorted(node.items())})


def _dict_doc_of(features: dict[str, Any]) -> dict[str, Any]:
    return {"pythonClassName": _TFDS + "features_dict.FeaturesDict", "featuresDict": {"features": features}}


@dataclass
class SplitShards:
    """A split as dataset_info.json lists it: its shards' episode counts, their bytes."""

    name: str
    shard_lengths: list[int]
    num_bytes: int


def dataset_info_doc(name: str, splits: Sequence[SplitShards], description: str) -> dict[str, Any]:
    """dataset_info.json as TFDS writes it (the fields `builder_from_directory` reads)."""
    return {
        "name": name,
        "version": VERSION,
        "fileFormat": "tfrecord",
        "moduleName": name,
        "description": description,
        "splits": [
            {
                "name": s.name,
                "filepathTemplate": "{DATASET}-{SPLIT}.{FILEFORMAT}-{SHARD_X_OF_Y}",
                "shardLengths": [str(n) for n in s.shard_lengths],
                "numBytes": str(s.num_bytes),
            }
            for s in splits
        ],
    }


def shard_name(name: str, split: str, shard: int, shards: int) -> str:
    return f"{name}-{split}.tfrecord-{shard:05d}-of-{shards:05d}"


def write_json(path: Path, doc: dict[str, Any]) -> None:
    path.write_text(json.dumps(doc, indent=2) + "\n", encoding="utf-8")


class ShardWriter:
    """One shard file, record after record."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.bytes = 0
        self.records = 0
        self._f = path.open("wb")

    def write(self, data: bytes) -> None:
        record = framed(data)
        self._f.write(record)
        self.bytes += len(record)
        self.records += 1

    def close(self) -> None:
        self._f.close()
