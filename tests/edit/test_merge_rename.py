"""`episodes merge` of datasets that differ: `--rename DATASET:OLD=NEW` aligns keys (packets copied), a camera
whose encoder parameters (codec, resolution) differ from the first dataset's is re-encoded to them while every
other stream is copied; lerobot 0.6.1 loads the result with the sources' frames; what cannot be aligned (fps, a
feature on one side only, state names) is refused in one line naming both datasets, nothing written."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from openral_data.doctor import check
from openral_data.edit import features
from openral_data.edit.videos import reencode
from tests.support.curate import lerobot_items, packets, refused, stream
from tests.support.inproc import run_inproc
from tests.support.lerobot_written import LENGTHS, VIDEO_CAMERA, digest, write_lerobot_dataset

FRONT = "observation.images.front"
KEYS = [VIDEO_CAMERA, "observation.state", "action"]


@pytest.fixture(scope="module")
def lerobot(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("merge") / "lerobot"
    write_lerobot_dataset(root, with_success=True)
    return root


def _merged(*args: str) -> None:
    res = run_inproc("episodes", "merge", *args)
    assert res.returncode == 0, res.stderr


def test_rename_aligns_a_camera_key_and_copies_its_packets(lerobot: Path, tmp_path: Path) -> None:
    front = features.rename(lerobot, VIDEO_CAMERA, FRONT, tmp_path / "front").out
    before = digest(front)
    out = tmp_path / "merged"
    _merged(str(lerobot), str(front), "--rename", f"{front}:{FRONT}={VIDEO_CAMERA}", "--out", str(out))
    assert check(out, deep=True) == []
    assert packets(out, VIDEO_CAMERA) == packets(lerobot, VIDEO_CAMERA) * 2  # nothing re-encoded
    want = lerobot_items(lerobot, KEYS)
    got = lerobot_items(out, KEYS)
    assert len(got) == 2 * sum(LENGTHS)
    for g, w in zip(got, want + want, strict=True):
        assert all(np.array_equal(g[k], w[k]) for k in KEYS)
    edit = json.loads((out / "meta/openral.json").read_text())["edit"]
    assert edit["renamed"] == {str(front): {FRONT: VIDEO_CAMERA}}
    assert digest(front) == before


def test_streams_whose_encoder_differs_are_reencoded_the_rest_copied(lerobot: Path, tmp_path: Path) -> None:
    av1 = reencode(lerobot, "av1", out=tmp_path / "av1").out  # our encoder, another codec
    big = reencode(lerobot, "h264", size="48x48", out=tmp_path / "big").out  # another resolution
    out = tmp_path / "merged"
    _merged(str(lerobot), str(av1), str(big), "--out", str(out))
    assert check(out, deep=True) == []
    assert stream(out, VIDEO_CAMERA) == {("h264", 32, 32, "yuv420p")}  # one stream, the first dataset's
    assert packets(out, VIDEO_CAMERA)[: len(packets(lerobot, VIDEO_CAMERA))] == packets(lerobot, VIDEO_CAMERA)
    want = lerobot_items(lerobot, KEYS)
    got = lerobot_items(out, KEYS)
    for g, w in zip(got, want * 3, strict=True):
        assert np.array_equal(g["observation.state"], w["observation.state"])
        assert np.array_equal(g["action"], w["action"])
        assert np.abs(g[VIDEO_CAMERA] - w[VIDEO_CAMERA]).max() <= 0.05  # decoded pixels within codec tolerance
    for g, w in zip(got[: sum(LENGTHS)], want, strict=True):
        assert np.array_equal(g[VIDEO_CAMERA], w[VIDEO_CAMERA])  # the copied stream: exact
    edit = json.loads((out / "meta/openral.json").read_text())["edit"]
    assert edit["reencoded"] == {str(av1.resolve()): ["cam"], str(big.resolve()): ["cam"]}


def _edited_copy(src: Path, dst: Path, **info_over: object) -> Path:
    shutil.copytree(src, dst)
    info = json.loads((dst / "meta/info.json").read_text())
    (dst / "meta/info.json").write_text(json.dumps({**info, **info_over}))
    return dst


def test_what_cannot_be_aligned_is_refused_naming_both(lerobot: Path, tmp_path: Path) -> None:
    out = tmp_path / "out"
    other_fps = _edited_copy(lerobot, tmp_path / "fps", fps=20)
    line = refused("episodes", "merge", str(lerobot), str(other_fps), "--out", str(out))
    assert line == f"error: {other_fps}/meta/info.json: fps: 20 differs from {lerobot}'s 10"
    feats = json.loads((lerobot / "meta/info.json").read_text())["features"]
    state = {**feats["observation.state"], "names": ["a", "b", "c"]}
    meaning = _edited_copy(lerobot, tmp_path / "names", features={**feats, "observation.state": state})
    line = refused("episodes", "merge", str(lerobot), str(meaning), "--out", str(out))
    assert line == (
        f"error: {meaning}/meta/info.json: features.observation.state.names (['a', 'b', 'c'] vs ['x', 'y', 'z']): "
        f"differs from {lerobot}"
    )
    front = features.rename(lerobot, VIDEO_CAMERA, FRONT, tmp_path / "front").out
    line = refused("episodes", "merge", str(lerobot), str(front), "--out", str(out))
    assert f"features.{VIDEO_CAMERA}: in {lerobot}, not in {front}" in line and "--rename" in line
    for spec, says in [
        (f"{front}:{FRONT}", "is not DATASET:OLD=NEW"),
        (f"elsewhere:{FRONT}={VIDEO_CAMERA}", "'elsewhere' is not one of the datasets merged"),
        (f"{front}:{FRONT}=index", "index is a name openral-data and lerobot reserve"),
    ]:
        assert says in refused("episodes", "merge", str(lerobot), str(front), "--rename", spec, "--out", str(out))
    assert not out.exists()
