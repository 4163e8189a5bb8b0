"""Zarr replay buffers and RLDS build folders damaged the ways `tests/formats` damages them (missing
meta/episode_ends, ragged arrays, wrong dtypes, huge declared shapes, truncated or mis-checksummed TFRecords, ...),
refused by `info SRC` in one line naming the file and key; and `info` / `convert --print-mapping` of broken bags."""

from __future__ import annotations

import re
from collections.abc import Callable
from pathlib import Path

from tests.malformed.corpus.cases import case
from tests.support import replay_buffer, rlds_written
from tests.support.malformed import Workspace

# the damages `info` meets (the rest, a corrupt chunk or a picture of the wrong size, only when rows are read)
_RLDS_INFO = ("truncated", "bad-crc", "huge-record", "not-an-example", "missing-key", "ragged", "wrong-type",
              "huge-shape", "zlib-tensor", "many-strings")  # fmt: skip


def _zarr_case(name: str, damage: Callable[[Path], None], says: str) -> None:
    def build(w: Workspace) -> list[str]:
        path = replay_buffer.write_replay_buffer(w.root / "b.zarr", replay_buffer.sample_episodes())
        damage(path)
        return ["info", str(path)]

    case(f"zarr-{name}", build, re.escape("b.zarr: ") + says)


def _rlds_case(name: str, damage: Callable[[Path], None], says: str) -> None:
    def build(w: Workspace) -> list[str]:
        path = rlds_written.write_rlds(w.root / "toy")
        damage(path)
        return ["info", str(path)]

    case(f"rlds-{name}", build, says)


for _name, (_damage, _says) in replay_buffer.DAMAGES.items():
    _zarr_case(_name, _damage, _says)
for _name in _RLDS_INFO:
    _rlds_case(_name, *rlds_written.DAMAGES[_name])
case("zarr-zip-garbage", lambda w: ["info", str(w.write("b.zarr.zip", b"PK\x03\x04garbage"))], r"b\.zarr\.zip: zip: ")
case("rlds-features-not-json", lambda w: ["info", str(w.write("r/features.json", "{").parent)], r"features\.json")
case("info-bag-garbage", lambda w: ["info", str(w.write("g.mcap", b"\x89MCAP0\r\n" + b"x" * 500))], r"g\.mcap")
case(
    "print-mapping-bag-garbage",
    lambda w: ["convert", str(w.write("g.bag", b"#ROSBAG V2.0\n" + b"\x00" * 300)), "--print-mapping"],
    r"g\.bag",
)


def _zarr_chunk_case(name: str, chunk: bytes | None, says: str) -> None:
    """data/action's chunk 0.0 zstd-compressed by its .zarray, replaced by `chunk` (None: a FIFO) (#49)."""

    def build(w: Workspace) -> list[str]:
        path = replay_buffer.write_replay_buffer(w.root / "b.zarr", replay_buffer.sample_episodes())
        replay_buffer.replace_chunk(path, {"id": "zstd", "level": 1}, chunk)
        return ["convert", str(path), str(w.root / "o"), "--fps", "10", "--codec", "h264"]

    case(f"zarr-{name}", build, re.escape("b.zarr: data/action/0.0: ") + says, ("o",))


_ZSTD_HEADER = b"\x28\xb5\x2f\xfd\xe0" + (1 << 40).to_bytes(8, "little")  # one frame of 1 TB, single segment
_ZSTD_1TB = _ZSTD_HEADER + (1 | (64 << 3)).to_bytes(3, "little") + bytes(64)  # then one raw 64-byte block
_zarr_chunk_case("zstd-chunk-claims-1tb", _ZSTD_1TB, "a zstd chunk claiming")
_zarr_chunk_case("fifo-chunk", None, "not a regular file")
