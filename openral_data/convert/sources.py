"""Finding the bags in a `convert` source and reading vectors and images out of their messages.

A source is a ROS 1 ``.bag`` file, a rosbag2 directory (``metadata.yaml`` + sqlite3 or mcap storage), a plain
``.mcap`` file with ros2msg schemas, or a directory holding any number of those (each one a bag, in name
order; hidden entries such as an unfinished ``.partial/`` episode are ignored). An ``.mcap`` of another profile
(Foxglove's, the `mcap` library's: protobuf, JSON, ROS 1 messages) is read by `formats.mcap.foreign`, its
messages decoded into `Fields` that the rest reads as it reads rosbags' messages.
"""

from __future__ import annotations

import struct
from collections.abc import Iterator
from pathlib import Path
from typing import Any, NoReturn

import numpy as np
import numpy.typing as npt
from rosbags.highlevel import AnyReader, AnyReaderError
from rosbags.interfaces import Connection
from rosbags.rosbag1 import ReaderError as Ros1ReaderError
from rosbags.rosbag2 import ReaderError as Ros2ReaderError
from rosbags.serde import SerdeError
from rosbags.typesys import Stores, get_typestore

from openral_data.convert.bag_paths import folder_bags, is_bag
from openral_data.errors import BagError, NotFound
from openral_data.formats.mcap.chunks import check_bag
from openral_data.formats.mcap.foreign import FOXGLOVE_IMAGE_TYPES, Fields, ForeignMcap, is_foreign_mcap
from openral_data.formats.mcap.messages import DEPTH_ENCODINGS, RGB_ENCODINGS
from openral_data.formats.rosbag1 import deserialize_ros1
from openral_data.schemas.mapping import Vector, VectorSource


def find_bags(src: Path) -> list[Path]:
    if not src.exists():
        raise NotFound(f"{src}: no such file or directory")
    if is_bag(src):
        return [src]
    if bags := folder_bags(src):
        return bags
    raise BagError(
        f"{src}: not a bag: expected a ROS 1 .bag, a plain .mcap, a rosbag2 folder (metadata.yaml) "
        "or a folder of those",
        code="bag.invalid",
    )


# what a damaged bag raises while it is opened or read (UnicodeDecodeError is a ValueError)
BAG_READ_ERRORS = (
    AnyReaderError,
    Ros1ReaderError,
    Ros2ReaderError,
    SerdeError,
    OSError,
    ValueError,
    KeyError,
    EOFError,
)


BagReader = AnyReader | ForeignMcap  # rosbags' reader, or an MCAP file of another profile


def open_reader(bag: Path) -> BagReader:
    """The bag opened for reading; an empty, truncated or garbage bag raises a `BagError` naming it."""
    if is_foreign_mcap(bag):
        return ForeignMcap(bag)
    store = get_typestore(Stores.ROS1_NOETIC if bag.suffix == ".bag" else Stores.ROS2_HUMBLE)
    check_bag(bag)  # bounded chunks and records, before rosbags allocates what they declare
    reader = AnyReader([bag], default_typestore=store)
    try:
        reader.open()
    except BAG_READ_ERRORS as exc:
        raise BagError(f"{bag}: cannot read bag: {exc}", code="bag.invalid") from None
    return reader


def read_messages(reader: BagReader, bag: Path, conns: list[Connection]) -> Iterator[tuple[Connection, int, bytes]]:
    """`reader.messages(connections=conns)`; a chunk that cannot be read (bad checksum, cut short) raises a
    `BagError` naming the bag."""
    it = reader.messages(connections=conns)
    while True:
        try:
            item = next(it)
        except StopIteration:
            return
        except BAG_READ_ERRORS as exc:
            raise BagError(f"{bag}: cannot read bag: {exc}", code="bag.invalid") from None
        yield item


def deserialize(reader: BagReader, bag: Path, raw: bytes, msgtype: str) -> Any:
    """One message decoded; bytes that do not decode as `msgtype` raise a `BagError` naming the bag. A ROS 1
    message's bytes after its last field are ignored (`deserialize_trailing`)."""
    return deserialize_trailing(reader, bag, raw, msgtype)[0]


def deserialize_trailing(reader: BagReader, bag: Path, raw: bytes, msgtype: str) -> tuple[Any, int]:
    """`deserialize`, and the bytes after the message's last field (ROS 1 only, which ignores them as ROS 1's own
    reader does; 0 for ROS 2, whose CDR messages rosbags reads padding and all, and for other MCAP profiles)."""
    if isinstance(reader, ForeignMcap):
        return reader.decode(raw, msgtype), 0
    try:
        if reader.is2:
            return reader.deserialize(raw, msgtype), 0
        return deserialize_ros1(reader.typestore, raw, msgtype)
    except (*BAG_READ_ERRORS, struct.error, IndexError, TypeError) as exc:
        raise BagError(f"{bag}: a {msgtype} message does not decode: {exc}", code="bag.invalid") from None


IMAGE_TYPES = ("sensor_msgs/msg/Image", "sensor_msgs/msg/CompressedImage", *FOXGLOVE_IMAGE_TYPES)


def check_camera(reader: BagReader, bag: Path, name: str, conn: Connection) -> None:
    """Before anything is written: camera `name`'s topic carries RGB images. A non-image topic, or images in a
    depth or otherwise unsupported encoding (read from its first message), raise one `BagError` line."""
    where = f"{bag}: mapping: cameras.{name} ({conn.topic})"
    if conn.msgtype not in IMAGE_TYPES:
        raise BagError(
            f"{where}: the topic carries {conn.msgtype}, not images (a camera needs "
            f"{', '.join(IMAGE_TYPES[:-1])} or {IMAGE_TYPES[-1]})",
            code="bag.type",
        )
    for c, _, raw in read_messages(reader, bag, [conn]):
        check_image(deserialize(reader, bag, raw, c.msgtype), c.msgtype, where)
        return


def check_image(msg: Any, msgtype: str, where: str) -> None:
    """An image message `decode_image` can turn into RGB: a raw image's encoding, or a compressed image that is
    not a depth image (``format: "16UC1; compressedDepth png"``); else a one-line `BagError`."""
    if msgtype.endswith("CompressedImage"):  # sensor_msgs/msg/CompressedImage, foxglove.CompressedImage
        fmt = str(msg.format)
        if "compresseddepth" in fmt.lower() or fmt.split(";", maxsplit=1)[0].strip().lower() in DEPTH_ENCODINGS:
            _depth(f"a CompressedImage of format {fmt!r}", where)
        return
    encoding = str(msg.encoding)
    if encoding.lower() in DEPTH_ENCODINGS:
        _depth(encoding, where)
    if encoding.lower() not in RGB_ENCODINGS:
        raise BagError(
            f"{where}: unsupported image encoding {encoding!r} (a camera needs {', '.join(RGB_ENCODINGS)})",
            code="bag.type",
        )


def _depth(what: str, where: str) -> NoReturn:
    raise BagError(
        f"{where}: {what} is a depth image, not an RGB camera "
        "(map a 16UC1/32FC1 depth topic under depth_cameras instead)",
        code="bag.type",
    )


def field_value(msg: Any, path: str, where: str) -> Any:
    value = msg
    for part in path.split("."):
        if not hasattr(value, part):
            fields = (
                value.field_names()
                if isinstance(value, Fields)
                else [k for k in getattr(type(value), "__dataclass_fields__", {})]
            )
            raise BagError(
                f"{where}: message has no field {path!r} (fields here: {', '.join(fields) or '-'})", code="bag.field"
            )
        value = getattr(value, part)
    return value


class VectorReader:
    """Turns one topic's messages into float32 vectors as one part of a mapped state or action says.

    `label` is where the part is in the mapping (`state`, `action.parts[1]`); errors name the bag, the label, the
    topic and the field. The width is fixed by the first message (or by `joints`): a later message of another
    width is an error, never padded or cut."""

    def __init__(self, source: VectorSource, label: str) -> None:
        self.source = source
        self.label = f"mapping: {label} ({source.topic}.{source.field})"
        self.dim: int | None = len(source.joints) if source.joints else None
        self._index_cache: tuple[tuple[str, ...], list[int]] | None = None

    def __call__(self, msg: Any, bag: Path) -> npt.NDArray[np.float32]:
        where = f"{bag}: {self.label}"
        raw = field_value(msg, self.source.field, where)
        try:
            values: npt.NDArray[np.float64] = np.asarray(raw, dtype=np.float64).reshape(-1)
        except (TypeError, ValueError):
            kind = getattr(raw, "__msgtype__", None)
            what = f"a {kind} message" if isinstance(kind, str) else type(raw).__name__
            raise BagError(f"{where}: field is {what}, not numbers", code="bag.field") from None
        if self.source.joints is not None:
            names = tuple(str(n) for n in field_value(msg, "name", where))
            if self._index_cache is None or self._index_cache[0] != names:
                missing = [j for j in self.source.joints if j not in names]
                if missing:
                    raise BagError(
                        f"{where}: joints {missing} not in the message's names {list(names)}", code="bag.field"
                    )
                self._index_cache = (names, [names.index(j) for j in self.source.joints])
            idx = self._index_cache[1]
            if len(values) < len(names):
                raise BagError(f"{where}: {len(values)} values for {len(names)} joint names", code="bag.field")
            values = np.asarray(values[idx])
        if self.dim is None:
            if not len(values):
                raise BagError(f"{where}: the field is empty (no values to map)", code="bag.field")
            if self.source.names is not None and len(self.source.names) != len(values):
                raise BagError(
                    f"{where}: names has {len(self.source.names)} entries for {len(values)} values", code="bag.field"
                )
            self.dim = len(values)
        elif len(values) != self.dim:
            raise BagError(f"{where}: vector length changed from {self.dim} to {len(values)}", code="bag.field")
        return values.astype(np.float32)

    def names(self) -> list[str]:
        """The part's dimension names: `names`, else `joints`, else `<topic>.<field>[i]`."""
        fixed = self.source.fixed_names()
        if fixed is not None:
            return list(fixed)
        return [f"{self.source.topic.strip('/')}.{self.source.field}[{i}]" for i in range(self.dim or 0)]


class VectorParts:
    """A mapped state or action: its parts' readers, in order; the vector is their concatenation."""

    def __init__(self, role: str, vector: Vector) -> None:
        self.role = role
        pairs = zip(vector.sources(), vector.labels(), strict=True)
        self.readers = [VectorReader(part, f"{role}.{label}" if label else role) for part, label in pairs]

    def names(self) -> list[str]:
        """Every dimension's name, in order (the parts' names concatenated); a name given twice is an error."""
        out: list[str] = []
        for reader in self.readers:
            for name in reader.names():
                if name in out:
                    raise BagError(f"{reader.label}: dimension name {name!r} is used twice in {self.role}",
                                   code="bag.field")  # fmt: skip
                out.append(name)
        return out
