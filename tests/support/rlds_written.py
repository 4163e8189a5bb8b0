"""A small RLDS build folder in the Open X-Embodiment layout, its records written by the `tfrecord` package.

What wrote what: every `*.tfrecord-NNNNN-of-NNNNN` record (TFRecord framing with masked CRC-32C, and the
`tf.train.Example` protobuf from tfrecord's own compiled example.proto) is written by `tfrecord.TFRecordWriter`
(PyPI `tfrecord`, a dev dependency), not by our reader's code. The Example's keys and lists are the ones TFDS's
example serializer gives an RLDS episode (`steps/...` flattened, each step's values concatenated; images one
JPEG/PNG bytes entry a step; bools as int64), and features.json / dataset_info.json are the documents a TFDS
builder writes beside them (the OXE shape, e.g. a `tensorflow_datasets.core.features.dataset_feature.Dataset`
named `steps`). TensorFlow + tensorflow-datasets would add several hundred MB to every CI install for these few
kilobytes, so they are not used.
"""

from __future__ import annotations

import io
import json
import struct
import zlib
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from PIL import Image

from tests.support.hdf5_layouts import SIZE, picture

_TFDS = "tensorflow_datasets.core.features."
STATE, ACTION, H, W = 8, 7, 12, 16


def _tensor(shape: list[int], dtype: str, cls: str = "tensor_feature.Tensor") -> dict[str, Any]:
    dims = {"dimensions": [str(d) for d in shape]} if shape else {}
    return {"pythonClassName": _TFDS + cls, "tensor": {"shape": dims, "dtype": dtype, "encoding": "none"}}


def _scalar(dtype: str) -> dict[str, Any]:
    return _tensor([], dtype, "scalar.Scalar")


def _image(fmt: str, size: tuple[int, int]) -> dict[str, Any]:
    shape = {"dimensions": [str(size[0]), str(size[1]), "3"]}
    return {"pythonClassName": _TFDS + "image_feature.Image",
            "image": {"shape": shape, "dtype": "uint8", "encodingFormat": fmt}}  # fmt: skip


def _dict(features: dict[str, Any]) -> dict[str, Any]:
    return {"pythonClassName": _TFDS + "features_dict.FeaturesDict", "featuresDict": {"features": features}}


def features_doc(size: tuple[int, int] = (H, W)) -> dict[str, Any]:
    step = _dict(
        {
            "observation": _dict(
                {
                    "image": _image("jpeg", size),
                    "wrist_image": _image("png", size),
                    "state": _tensor([STATE], "float32"),
                }
            ),
            "action": _tensor([ACTION], "float32"),
            "language_instruction": {"pythonClassName": _TFDS + "text_feature.Text", "text": {}},
            "is_first": _scalar("bool"),
            "is_last": _scalar("bool"),
            "is_terminal": _scalar("bool"),
            "reward": _scalar("float32"),
            "discount": _scalar("float32"),
        }
    )
    steps = {"pythonClassName": _TFDS + "dataset_feature.Dataset", "sequence": {"feature": step, "length": "-1"}}
    meta = _dict({"file_path": {"pythonClassName": _TFDS + "text_feature.Text", "text": {}}})
    return _dict({"steps": steps, "episode_metadata": meta})


def _encode(pixels: np.ndarray, fmt: str) -> bytes:
    out = io.BytesIO()
    Image.fromarray(pixels).save(out, format=fmt.upper())
    return out.getvalue()


def episode_datum(n: int, rng: np.random.Generator, index: int, smooth: bool = False) -> dict[str, tuple[Any, str]]:
    """One episode as `TFRecordWriter.write` takes it: key -> (values, "byte"|"float"|"int"). `smooth`: 64x64
    gradients (`hdf5_layouts.picture`, checkable through lossy video) instead of 12x16 noise."""
    pictures = rng.integers(0, 256, (2, n, H, W, 3), dtype=np.uint8)
    if smooth:
        pictures = np.stack([np.stack([picture(index, t, c) for t in range(n)]) for c in range(2)])
    last = [0] * (n - 1) + [1]
    return {
        "steps/observation/image": ([_encode(p, "jpeg") for p in pictures[0]], "byte"),
        "steps/observation/wrist_image": ([_encode(p, "png") for p in pictures[1]], "byte"),
        "steps/observation/state": (rng.standard_normal(n * STATE).astype(np.float32).tolist(), "float"),
        "steps/action": (rng.standard_normal(n * ACTION).astype(np.float32).tolist(), "float"),
        "steps/language_instruction": ([f"pick up block {index}".encode()] * n, "byte"),
        "steps/is_first": ([1] + [0] * (n - 1), "int"),
        "steps/is_last": (last, "int"),
        "steps/is_terminal": (last, "int"),
        "steps/reward": ([float(x) for x in last], "float"),
        "steps/discount": ([1.0] * n, "float"),
        "episode_metadata/file_path": ([f"/raw/episode_{index}.npy".encode()], "byte"),
    }


def write_rlds(
    folder: Path,
    lengths: tuple[tuple[int, ...], ...] = ((4, 6), (5,)),
    seed: int = 0,
    *,
    smooth: bool = False,
    splits: dict[str, tuple[tuple[int, ...], ...]] | None = None,
) -> Path:
    """A TFDS build folder `folder` (`toy_rlds/1.0.0`-like): one shard per entry of `lengths`, one episode per
    length in it (`smooth`: 64x64 gradient pictures, see `episode_datum`). `splits`: several splits as TFDS
    writes them (split name -> its shards' lengths; `toy_rlds-<split>.tfrecord-NNNNN-of-NNNNN` shards, each
    split's `shardLengths` in dataset_info.json), instead of `lengths` as the one `train` split; episodes are
    numbered across splits in the order given (episode i's instruction is "pick up block i")."""
    from tfrecord import TFRecordWriter

    folder.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(seed)
    index = 0
    split_info = []
    for split, shards in (splits or {"train": lengths}).items():
        shard_lengths = []
        for shard, episodes in enumerate(shards):
            writer = TFRecordWriter(str(folder / f"toy_rlds-{split}.tfrecord-{shard:05d}-of-{len(shards):05d}"))
            for n in episodes:
                writer.write(episode_datum(n, rng, index, smooth))
                index += 1
            writer.close()
            shard_lengths.append(str(len(episodes)))
        split_info.append({"name": split, "shardLengths": shard_lengths, "numBytes": "0"})
    size = (SIZE, SIZE) if smooth else (H, W)
    (folder / "features.json").write_text(json.dumps(features_doc(size), indent=2))
    info = {"name": "toy_rlds", "version": "1.0.0", "fileFormat": "tfrecord", "moduleName": "toy_rlds",
            "splits": split_info}  # fmt: skip
    (folder / "dataset_info.json").write_text(json.dumps(info, indent=2))
    return folder


SHARD = "toy_rlds-train.tfrecord-00000-of-00002"


def _crc(data: bytes) -> bytes:
    from tfrecord.writer import TFRecordWriter

    crc: bytes = TFRecordWriter.masked_crc(data)
    return crc


def _record(data: bytes) -> bytes:
    """One TFRecord record framed by tfrecord's own masked CRC."""
    head = struct.pack("<Q", len(data))
    return head + _crc(head) + data + _crc(data)


def _shard(folder: Path) -> Path:
    return folder / SHARD


def _truncate(folder: Path) -> None:
    raw = _shard(folder).read_bytes()
    _shard(folder).write_bytes(raw[: len(raw) - 40])


def _bad_crc(folder: Path) -> None:
    raw = bytearray(_shard(folder).read_bytes())
    raw[100] ^= 0xFF
    _shard(folder).write_bytes(bytes(raw))


def _huge_record(folder: Path) -> None:
    head = struct.pack("<Q", 1 << 40)
    _shard(folder).write_bytes(head + _crc(head))


def _not_an_example(folder: Path) -> None:
    _shard(folder).write_bytes(_record(b"\xff\xff\xff\xff"))


def _rewrite(folder: Path, change: Callable[[dict], None]) -> None:
    from tfrecord.writer import TFRecordWriter

    datum = episode_datum(4, np.random.default_rng(1), 0)
    change(datum)
    _shard(folder).write_bytes(_record(TFRecordWriter.serialize_tf_example(datum)))


def _missing_key(folder: Path) -> None:
    _rewrite(folder, lambda d: d.pop("steps/action"))


def _ragged(folder: Path) -> None:
    _rewrite(folder, lambda d: d.update({"steps/is_first": ([1, 0, 0], "int")}))


def _wrong_type(folder: Path) -> None:
    _rewrite(folder, lambda d: d.update({"steps/reward": ([0, 0, 0, 1], "int")}))


def _features(folder: Path, change: Callable[[dict], None]) -> None:
    doc = json.loads((folder / "features.json").read_text())
    change(doc["featuresDict"]["features"]["steps"]["sequence"]["feature"]["featuresDict"]["features"])
    (folder / "features.json").write_text(json.dumps(doc))


def _huge_shape(folder: Path) -> None:
    _features(folder, lambda f: f["action"]["tensor"]["shape"].update({"dimensions": ["100000000000"]}))


def _zlib_tensor(folder: Path) -> None:
    _features(folder, lambda f: f["action"]["tensor"].update({"encoding": "zlib"}))


def _declared_smaller(folder: Path) -> None:
    def change(f: dict) -> None:
        f["observation"]["featuresDict"]["features"]["image"]["image"]["shape"]["dimensions"] = ["10", "16", "3"]

    _features(folder, change)


def bomb_png(side: int = 12000) -> bytes:
    """A valid 1-bit grey PNG of `side`x`side` black pixels: a few kB whose pixels decode to side² bytes and
    more (hand-framed: IHDR, one IDAT compressed row by row, IEND; PIL would hold the whole picture to write it)."""

    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    packer = zlib.compressobj(9)
    row = bytes(1 + (side + 7) // 8)  # filter byte 0, then the row's bits
    idat = b"".join(packer.compress(row) for _ in range(side)) + packer.flush()
    ihdr = struct.pack(">IIBBBBB", side, side, 1, 0, 0, 0, 0)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", idat) + chunk(b"IEND", b"")


def _variable_huge_pictures(folder: Path) -> None:
    """features.json declares the wrist camera `[-1, -1, 3]` and its first picture is a 12000x12000 PNG."""

    def change(f: dict) -> None:
        f["observation"]["featuresDict"]["features"]["wrist_image"]["image"]["shape"]["dimensions"] = ["-1", "-1", "3"]

    _features(folder, change)
    _rewrite(folder, lambda d: d["steps/observation/wrist_image"][0].__setitem__(0, bomb_png()))


def _many_strings(folder: Path) -> None:
    """Episode-level `file_path` holding 3 M one-byte strings (a 9 MB record)."""
    _rewrite(folder, lambda d: d.update({"episode_metadata/file_path": ([b"x"] * 3_000_000, "byte")}))


# damage -> what the one-line refusal says (after the folder's path)
DAMAGES: dict[str, tuple[Callable[[Path], None], str]] = {
    "truncated": (_truncate, rf"{SHARD}: record 1: cut short"),
    "bad-crc": (_bad_crc, rf"{SHARD}: record 0: data checksum mismatch"),
    "huge-record": (_huge_record, rf"{SHARD}: record 0: 1099511627776 bytes, over the \d+-byte limit"),
    "not-an-example": (_not_an_example, rf"{SHARD}: record 0: not a tf.train.Example"),
    "missing-key": (_missing_key, rf"{SHARD}: record 0: steps/action: missing from the episode"),
    "ragged": (_ragged, rf"{SHARD}: record 0: steps/is_first: 3 steps, but steps/action has 4"),
    "wrong-type": (_wrong_type, rf"{SHARD}: record 0: steps/reward: stored as int64_list, features.json says float"),
    "huge-shape": (_huge_shape, r"features.json: steps/action: shape \[100000000000\] out of range"),
    "picture-size": (_declared_smaller, r"steps/observation/image: step 0: a 12x16 picture, features.json says 10x16"),
    "huge-picture": (_variable_huge_pictures, r"steps/observation/wrist_image: step 0: a 12000x12000 picture, over "),
    "many-strings": (_many_strings, rf"{SHARD}: record 0: episode_metadata/file_path: 3000000 strings, over the "),
    "zlib-tensor": (_zlib_tensor, r"features.json: steps/action: tensor of dtype float32, encoding zlib is not read"),
}
