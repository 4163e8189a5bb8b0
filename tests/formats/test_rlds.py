"""RLDS / TFDS episodes read through the episodic protocol: every value equals what the `tfrecord` package's own
reader (and PIL, for the encoded pictures) returns for the same records, and a damaged record or feature tree is
one `DatasetError` line naming the file and the record or key."""

from __future__ import annotations

import io
import json
import struct
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from PIL import Image

from openral_data.errors import DatasetError
from openral_data.formats.rlds import RldsSource, detect
from openral_data.formats.rlds.tfrecord import masked_crc
from tests.support.array_sources import assert_one_line, damaged, read_all
from tests.support.rlds_written import episode_datum, write_rlds

SHARD = "toy_rlds-train.tfrecord-00000-of-00002"


@pytest.fixture(scope="module")
def built(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return write_rlds(tmp_path_factory.mktemp("rlds") / "toy_rlds" / "1.0.0")


def _independent(folder: Path) -> list[dict[str, Any]]:
    from tfrecord.reader import tfrecord_loader

    out = []
    for shard in sorted(folder.glob("*.tfrecord-*")):
        out.extend(tfrecord_loader(str(shard), None))
    return out


def _picture(data: bytes) -> np.ndarray:
    with Image.open(io.BytesIO(data)) as img:
        return np.asarray(img.convert("RGB"))


def test_every_value_equals_the_tfrecord_reader(built: Path) -> None:
    source = detect(built)
    assert isinstance(source, RldsSource) and source.layout == "rlds" and source.fps is None
    theirs = _independent(built)
    episodes = list(source.episodes())
    assert [e.name for e in episodes] == ["train/0", "train/1", "train/2"] and len(theirs) == 3
    for ep, record in zip(episodes, theirs, strict=True):
        assert ep.meta.language == f"pick up block {ep.name[-1]}"
        assert ep.meta.attrs == {"episode_metadata/file_path": record["episode_metadata/file_path"].decode()}
        for spec in ep.specs():
            got = np.concatenate([ep.read(spec.key, 0, 2), ep.read(spec.key, 2, ep.length)])
            want = record[spec.key]
            if spec.encoding in ("jpeg", "png"):
                assert np.array_equal(got, np.stack([_picture(b) for b in want]))
            elif spec.dtype == "bytes":
                assert [bytes(v) for v in got] == [bytes(v) for v in want]
            else:
                assert got.dtype.name == spec.dtype
                assert np.array_equal(got, np.asarray(want).astype(spec.dtype).reshape(got.shape))
                assert got.shape == (ep.length, *spec.shape)


def test_a_folder_without_features_json_is_not_detected(tmp_path: Path) -> None:
    assert detect(tmp_path) is None


def _record(data: bytes) -> bytes:
    head = struct.pack("<Q", len(data))
    return head + struct.pack("<I", masked_crc(head)) + data + struct.pack("<I", masked_crc(data))


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
    _shard(folder).write_bytes(head + struct.pack("<I", masked_crc(head)))


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


CASES: dict[str, tuple[Callable[[Path], None], str]] = {
    "truncated": (_truncate, rf"{SHARD}: record 1: cut short"),
    "bad-crc": (_bad_crc, rf"{SHARD}: record 0: data checksum mismatch"),
    "huge-record": (_huge_record, rf"{SHARD}: record 0: 1099511627776 bytes, over the \d+-byte limit"),
    "not-an-example": (_not_an_example, rf"{SHARD}: record 0: not a tf.train.Example"),
    "missing-key": (_missing_key, rf"{SHARD}: record 0: steps/action: missing from the episode"),
    "ragged": (_ragged, rf"{SHARD}: record 0: steps/is_first: 3 steps, but steps/action has 4"),
    "wrong-type": (_wrong_type, rf"{SHARD}: record 0: steps/reward: stored as int64_list, features.json says float"),
    "huge-shape": (_huge_shape, r"features.json: steps/action: shape \[100000000000\] out of range"),
    "picture-size": (_declared_smaller, r"steps/observation/image: step 0: a 12x16 picture, features.json says 10x16"),
    "zlib-tensor": (_zlib_tensor, r"features.json: steps/action: tensor of dtype float32, encoding zlib is not read"),
}


@pytest.mark.parametrize("case", list(CASES))
def test_malformed_episodes_are_one_line(built: Path, tmp_path: Path, case: str) -> None:
    bad = damaged(built, tmp_path / "bad", CASES[case][0])
    with pytest.raises(DatasetError) as excinfo:
        read_all(detect(bad))
    assert_one_line(excinfo.value, bad, CASES[case][1])
