"""TFRecord files read record by record, and the `tf.train.Example` message declared here (no TensorFlow).

Written the same way (`framed`, `serialize_example`) by `writer`, the RLDS export.

A TFRecord file is a sequence of records, each ``uint64 length, uint32 masked_crc32c(length), bytes data[length],
uint32 masked_crc32c(data)`` (little-endian; tensorflow/core/lib/io/record_writer.cc). Both checksums are
verified. A record longer than `MAX_RECORD_BYTES` is refused before it is read, so memory is bounded by one record
(an RLDS episode), and an Example's lists by `MAX_STRINGS` / `MAX_NUMBERS` values a feature before they are
turned into Python objects. The `Example` message is built from a hand-written descriptor of tensorflow's
core/example/example.proto and feature.proto (field numbers and types as there), parsed by `protobuf`.
"""

from __future__ import annotations

import struct
from collections.abc import Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any

import google_crc32c
from google.protobuf import descriptor_pb2, descriptor_pool, message_factory
from google.protobuf.message import DecodeError

from openral_data.errors import DatasetError

# one record (one RLDS episode, its encoded images included) is read whole: larger ones are refused
MAX_RECORD_BYTES = 1 << 30
# values of one feature of one record: a bytes list costs a Python object a value (a million steps an episode is
# far more than any RLDS dataset has), a number list 8 bytes a value
MAX_STRINGS = 1 << 20
MAX_NUMBERS = 1 << 25
_MASK_DELTA = 0xA282EAD8


def masked_crc(data: bytes) -> int:
    """TFRecord's masked CRC-32C of `data`."""
    crc = int(google_crc32c.value(data))
    return (((crc >> 15) | (crc << 17)) + _MASK_DELTA) & 0xFFFFFFFF


def records(path: Path, limit: int = MAX_RECORD_BYTES) -> Iterator[bytes]:
    """Every record of the TFRecord file `path`, checksums verified; a damaged file raises `DatasetError` naming
    the file and the record."""
    with path.open("rb") as f:
        index = 0
        while True:
            head = f.read(12)
            if not head:
                return
            where = f"{path}: record {index}"
            if len(head) < 12:
                raise DatasetError(f"{where}: cut short in its length header", code="dataset.invalid")
            length, length_crc = struct.unpack("<QI", head)
            if masked_crc(head[:8]) != length_crc:
                raise DatasetError(f"{where}: length checksum mismatch (not a TFRecord file?)", code="dataset.invalid")
            if length > limit:
                raise DatasetError(f"{where}: {length} bytes, over the {limit}-byte limit", code="dataset.invalid")
            data = f.read(length)
            tail = f.read(4)
            if len(data) < length or len(tail) < 4:
                raise DatasetError(f"{where}: cut short ({len(data)} of {length} bytes)", code="dataset.invalid")
            if masked_crc(data) != struct.unpack("<I", tail)[0]:
                raise DatasetError(f"{where}: data checksum mismatch", code="dataset.invalid")
            yield data
            index += 1


def _example_file() -> descriptor_pb2.FileDescriptorProto:
    """tensorflow/core/example/{feature,example}.proto as one descriptor (package tensorflow)."""
    f = descriptor_pb2.FileDescriptorProto(name="openral_tf_example.proto", package="tensorflow", syntax="proto3")
    lab = descriptor_pb2.FieldDescriptorProto
    for name, kind in (("BytesList", lab.TYPE_BYTES), ("FloatList", lab.TYPE_FLOAT), ("Int64List", lab.TYPE_INT64)):
        m = f.message_type.add(name=name)
        m.field.add(name="value", number=1, type=kind, label=lab.LABEL_REPEATED)
    feature = f.message_type.add(name="Feature")
    feature.oneof_decl.add(name="kind")
    for number, (name, kind) in enumerate(
        (("bytes_list", "BytesList"), ("float_list", "FloatList"), ("int64_list", "Int64List")), start=1
    ):
        feature.field.add(
            name=name, number=number, type=lab.TYPE_MESSAGE, type_name=f".tensorflow.{kind}",
            label=lab.LABEL_OPTIONAL, oneof_index=0,
        )  # fmt: skip
    features = f.message_type.add(name="Features")
    entry = features.nested_type.add(name="FeatureEntry")
    entry.options.map_entry = True
    entry.field.add(name="key", number=1, type=lab.TYPE_STRING, label=lab.LABEL_OPTIONAL)
    entry.field.add(
        name="value", number=2, type=lab.TYPE_MESSAGE, type_name=".tensorflow.Feature", label=lab.LABEL_OPTIONAL
    )
    features.field.add(
        name="feature", number=1, type=lab.TYPE_MESSAGE, type_name=".tensorflow.Features.FeatureEntry",
        label=lab.LABEL_REPEATED,
    )  # fmt: skip
    example = f.message_type.add(name="Example")
    example.field.add(
        name="features", number=1, type=lab.TYPE_MESSAGE, type_name=".tensorflow.Features", label=lab.LABEL_OPTIONAL
    )
    return f


_POOL = descriptor_pool.DescriptorPool()
_EXAMPLE: Any = message_factory.GetMessageClass(_POOL.Add(_example_file()).message_types_by_name["Example"])


def parse_example(data: bytes, where: str) -> dict[str, Any]:
    """A serialized `tf.train.Example` as {feature key: its `Feature` message}; bytes that are not one raise
    `DatasetError` naming `where`."""
    example = _EXAMPLE()
    try:
        example.ParseFromString(data)
    except DecodeError as exc:
        raise DatasetError(f"{where}: not a tf.train.Example: {exc}", code="dataset.invalid") from None
    features = dict(example.features.feature)
    for key, feature in features.items():
        kind = feature.WhichOneof("kind")
        count = len(getattr(feature, kind).value) if kind else 0
        limit, what = (MAX_STRINGS, "strings") if kind == "bytes_list" else (MAX_NUMBERS, "values")
        if count > limit:
            raise DatasetError(f"{where}: {key}: {count} {what}, over the {limit}-{what[:-1]} limit",
                               code="dataset.source.shape")  # fmt: skip
    return features


def framed(data: bytes) -> bytes:
    """`data` as one TFRecord record: its length, the length's masked CRC, the data, the data's masked CRC."""
    head = struct.pack("<Q", len(data))
    return head + struct.pack("<I", masked_crc(head)) + data + struct.pack("<I", masked_crc(data))


def serialize_example(features: Mapping[str, tuple[str, Sequence[Any]]]) -> bytes:
    """A `tf.train.Example` of `features` (key -> (proto list: bytes_list, float_list or int64_list, values)),
    serialized deterministically (its map in key order)."""
    example = _EXAMPLE()
    for key, (kind, values) in features.items():
        getattr(example.features.feature[key], kind).value.extend(values)
    data: bytes = example.SerializeToString(deterministic=True)
    return data
