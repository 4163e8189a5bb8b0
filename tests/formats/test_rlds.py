"""RLDS / TFDS episodes read through the episodic protocol: every value equals what the `tfrecord` package's own
reader (and PIL, for the encoded pictures) returns for the same records, and a damaged record or feature tree is
one `DatasetError` line naming the file and the record or key."""

from __future__ import annotations

import io
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from PIL import Image

from openral_data.errors import DatasetError
from openral_data.formats.rlds import RldsSource, detect
from tests.support.array_sources import assert_one_line, damaged, read_all
from tests.support.home import REPO
from tests.support.rlds_written import DAMAGES, write_rlds

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


TFDS_WRITTEN = REPO / "tests/fixtures/rlds"


def test_a_folder_tensorflow_datasets_wrote_reads_as_tfds_decodes_it() -> None:
    """tests/fixtures/rlds: written by tensorflow-datasets itself, with what tfds decodes from it beside it."""
    theirs = np.load(TFDS_WRITTEN / "tfds_decoded.npz")
    source = detect(TFDS_WRITTEN / "toy_rlds/1.0.0")
    assert source is not None
    episodes = list(source.episodes())
    assert [e.length for e in episodes] == [len(theirs[f"{i}|steps/action"]) for i in range(3)]
    for i, ep in enumerate(episodes):
        assert {s.key for s in ep.specs()} == {k.split("|")[1] for k in theirs if k.startswith(f"{i}|steps/")}
        for spec in ep.specs():
            got, want = ep.read(spec.key, 0, ep.length), theirs[f"{i}|{spec.key}"]
            if spec.dtype == "bytes":
                assert [bytes(v) for v in got] == [bytes(v) for v in want], spec.key
            elif spec.encoding == "jpeg":  # TensorFlow's and PIL's JPEG decoders (chroma upsampling) differ a little
                diff = np.abs(got.astype(int) - want)
                assert got.shape == want.shape and diff.mean() < 2.5 and diff.max() <= 16, spec.key
            else:
                assert got.dtype == want.dtype and np.array_equal(got, want), spec.key
        assert ep.meta.language == bytes(theirs[f"{i}|steps/language_instruction"][0]).decode()
        assert ep.meta.attrs == {
            "episode_metadata/episode_id": int(theirs[f"{i}|episode_metadata/episode_id"]),
            "episode_metadata/file_path": bytes(theirs[f"{i}|episode_metadata/file_path"]).decode(),
        }


def test_a_folder_without_features_json_is_not_detected(tmp_path: Path) -> None:
    assert detect(tmp_path) is None


@pytest.mark.parametrize("case", list(DAMAGES))
def test_malformed_episodes_are_one_line(built: Path, tmp_path: Path, case: str) -> None:
    bad = damaged(built, tmp_path / "bad", DAMAGES[case][0])
    with pytest.raises(DatasetError) as excinfo:
        read_all(detect(bad))
    assert_one_line(excinfo.value, bad, DAMAGES[case][1])
