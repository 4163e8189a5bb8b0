"""`videos reencode` and `videos encode-images`: the chosen cameras are decoded and encoded again (resized,
another codec, or from `dtype: image` pictures), the rest is copied; `doctor --deep` finds the output healthy,
lerobot 0.6.1 loads every frame (encoded pixels within codec loss, every other column exactly equal) and the
source is byte-unchanged. On our recordings and on datasets lerobot wrote itself."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import av
import numpy as np
import pyarrow.parquet as pq
import pytest

from openral_data.doctor import check
from openral_data.edit import videos
from openral_data.errors import DatasetBusy
from openral_data.formats.lerobot_v3.lock import DatasetLock
from tests.edit.test_edit import _digest, _record
from tests.support.cli import run_cli
from tests.support.curate import packets
from tests.support.lerobot_written import IMAGE_CAMERA, LENGTHS, image_pixels, write_lerobot_dataset

pytestmark = pytest.mark.slow
FRONT, WRIST, CAM = "observation.images.front", "observation.images.wrist", "observation.images.cam"
Frame = dict[str, Any]


def _frames(root: Path) -> list[Frame]:
    """Every frame lerobot 0.6.1 loads, cameras as uint8 HWC."""
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    ds = LeRobotDataset("local/check", root=root, video_backend="pyav")
    out: list[Frame] = []
    for i in range(len(ds)):
        item: Frame = {}
        for k, v in ds[i].items():
            if k in ds.meta.camera_keys:
                item[k] = np.round(v.numpy().transpose(1, 2, 0) * 255).astype(np.uint8)
            else:
                item[k] = v if isinstance(v, str) else v.numpy()
        out.append(item)
    return out


def _same_except(got: list[Frame], want: list[Frame], cameras: set[str]) -> None:
    """Same frames, same keys; every value exactly equal except the `cameras` (checked by the caller)."""
    assert len(got) == len(want)
    for g, w in zip(got, want, strict=True):
        assert g.keys() == w.keys()
        for k in g.keys() - cameras:
            assert np.array_equal(g[k], w[k]), k


def _mean_abs_error(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.abs(a.astype(np.float64) - b.astype(np.float64)).mean())


def _psnr(a: np.ndarray, b: np.ndarray) -> float:
    mse = float(((a.astype(np.float64) - b.astype(np.float64)) ** 2).mean())
    return 99.0 if mse == 0 else 10 * np.log10(255.0**2 / mse)


def _resized(frame: np.ndarray, width: int, height: int) -> np.ndarray:
    vf = av.VideoFrame.from_ndarray(frame, format="rgb24")
    return np.asarray(vf.reformat(width=width, height=height, interpolation="BILINEAR").to_ndarray(format="rgb24"))


def _feature(root: Path, key: str) -> dict[str, Any]:
    feature: dict[str, Any] = json.loads((root / "meta/info.json").read_text())["features"][key]
    return feature


def _episode_means(root: Path, key: str) -> list[np.ndarray]:
    rows = pq.read_table(root / "meta/episodes").to_pylist()
    return [np.asarray(r[f"stats/{key}/mean"], dtype=np.float64).reshape(3) for r in rows]


def test_reencode_one_camera_resized_to_av1(project: Path, tmp_path: Path) -> None:
    src = _record(project, tmp_path / "src", 0, 4)  # h264, front 64x48 and wrist 32x32
    before = _digest(src)
    out = tmp_path / "out"
    res = run_cli(
        "videos", "reencode", str(src), "--codec", "av1", "--size", "48x32", "--camera", "front", "--out", str(out)
    )
    assert res.returncode == 0, res.stderr
    assert res.stdout.strip() == f"reencoded: {out}  episodes 4  frames 24"
    assert check(out, deep=True) == []
    assert _digest(src) == before
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]

    front = _feature(out, FRONT)
    assert front["shape"] == [32, 48, 3]
    assert front["info"]["video.codec"] == "av1" and front["info"]["video.preset"] == 12
    assert (front["info"]["video.width"], front["info"]["video.height"]) == (48, 32)
    edit = json.loads((out / "meta/openral.json").read_text())["edit"]
    assert {k: edit[k] for k in ("op", "codec", "size", "cameras")} == {
        "op": "reencode",
        "codec": "av1",
        "size": "48x32",
        "cameras": [FRONT],
    }
    assert [s["path"] for s in edit["sources"]] == [str(src.resolve())]
    assert _feature(out, WRIST) == _feature(src, WRIST)  # not chosen: untouched, packets copied
    assert packets(out, WRIST) == packets(src, WRIST)
    with av.open(str(next((out / "videos" / FRONT).rglob("*.mp4")))) as c:
        stream = c.streams.video[0]
        assert (stream.codec_context.name, stream.width, stream.height) in {("libdav1d", 48, 32), ("av1", 48, 32)}

    want, got = _frames(src), _frames(out)
    _same_except(got, want, {FRONT})
    for g, w in zip(got, want, strict=True):
        assert g[FRONT].shape == (32, 48, 3)
        assert _mean_abs_error(g[FRONT], _resized(w[FRONT], 48, 32)) < 4.0
    # the camera statistics follow the new pixels: per episode and for the dataset (exact histograms kept)
    starts = np.cumsum([0, *[int(f) for f in (5, 9, 3, 7)]])
    for e, mean in enumerate(_episode_means(out, FRONT)):
        pixels = np.stack([f[FRONT] for f in got[starts[e] : starts[e + 1]]]).reshape(-1, 3) / 255.0
        assert np.allclose(mean, pixels.mean(axis=0), atol=0.02), (e, mean)
    stats = json.loads((out / "meta/stats.json").read_text())
    assert stats[FRONT]["count"] == [24]
    assert stats[WRIST] == json.loads((src / "meta/stats.json").read_text())[WRIST]
    hist = json.loads((out / ".openral/image_hist.json").read_text())
    assert (
        hist["front"]["frames"] == 24
        and hist["wrist"] == json.loads((src / ".openral/image_hist.json").read_text())["wrist"]
    )


def test_reencode_in_place_and_a_busy_dataset_is_refused(project: Path, tmp_path: Path) -> None:
    src = _record(project, tmp_path / "src", 0, 2, codec="av1")
    before = _digest(src)
    with DatasetLock(src, "test"), pytest.raises(DatasetBusy) as err:
        videos.reencode(src, "h264", in_place=True)
    assert err.value.code == "dataset.busy"
    assert _digest(src) == before
    want = _frames(src)
    res = run_cli("videos", "reencode", str(src), "--codec", "h264", "--in-place")
    assert res.returncode == 0, res.stderr
    assert check(src, deep=True) == []
    assert {_feature(src, k)["info"]["video.codec"] for k in (FRONT, WRIST)} == {"h264"}
    assert json.loads((src / "meta/openral.json").read_text())["config"]["codec"] == "h264"
    got = _frames(src)
    _same_except(got, want, {FRONT, WRIST})
    for g, w in zip(got, want, strict=True):
        for k in (FRONT, WRIST):
            assert _mean_abs_error(g[k], w[k]) < 3.0
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]  # the old folder and staging are gone


def test_reencode_a_lerobot_dataset(tmp_path: Path) -> None:
    src = tmp_path / "lerobot"
    write_lerobot_dataset(src, with_success=False, environment_state=True)  # h264 camera
    before = _digest(src)
    out = tmp_path / "out"
    res = run_cli("videos", "reencode", str(src), "--codec", "av1", "--out", str(out))
    assert res.returncode == 0, res.stderr
    assert check(out, deep=True) == []
    assert _digest(src) == before
    assert _feature(out, CAM)["info"]["video.codec"] == "av1" and _feature(out, CAM)["shape"] == [32, 32, 3]
    want, got = _frames(src), _frames(out)
    _same_except(got, want, {CAM})
    for g, w in zip(got, want, strict=True):
        assert _mean_abs_error(g[CAM], w[CAM]) < 3.0


def test_image_feature_becomes_a_video_camera(tmp_path: Path) -> None:
    src = tmp_path / "lerobot"
    write_lerobot_dataset(src, with_success=True, image_camera=True, environment_state=True)
    before = _digest(src)
    out = tmp_path / "out"
    res = run_cli("videos", "encode-images", str(src), "--codec", "h264", "--out", str(out))
    assert res.returncode == 0, res.stderr
    assert res.stdout.strip() == f"encoded: {out}  episodes 3  frames {sum(LENGTHS)}"
    assert check(out, deep=True) == []
    assert _digest(src) == before

    # the feature as lerobot writes a video feature (its own h264 camera's block, at this size)
    cam = _feature(src, CAM)
    h, w = _feature(src, IMAGE_CAMERA)["shape"][:2]
    assert _feature(out, IMAGE_CAMERA) == {
        **cam,
        "shape": [h, w, 3],
        "info": {**cam["info"], "video.height": h, "video.width": w},
    }
    edit = json.loads((out / "meta/openral.json").read_text())["edit"]
    assert (edit["op"], edit["codec"], edit["cameras"]) == ("encode-images", "h264", [IMAGE_CAMERA])
    assert IMAGE_CAMERA not in pq.read_schema(next((out / "data").rglob("*.parquet"))).names
    assert (out / "videos" / IMAGE_CAMERA / "chunk-000/file-000.mp4").is_file()
    rows = pq.read_table(out / "meta/episodes").to_pylist()
    assert [r[f"videos/{IMAGE_CAMERA}/from_timestamp"] for r in rows] == [0.0, 0.6, 1.5]
    assert [r[f"videos/{IMAGE_CAMERA}/to_timestamp"] for r in rows] == [0.6, 1.5, 1.9]
    assert {(r[f"videos/{IMAGE_CAMERA}/chunk_index"], r[f"videos/{IMAGE_CAMERA}/file_index"]) for r in rows} == {(0, 0)}

    want, got = _frames(src), _frames(out)
    _same_except(got, want, {IMAGE_CAMERA})
    k = 0
    for e, n in enumerate(LENGTHS):
        for t in range(n):
            assert np.array_equal(want[k][IMAGE_CAMERA], image_pixels(e, t))  # the source: lossless PNG
            assert _psnr(got[k][IMAGE_CAMERA], image_pixels(e, t)) > 30.0, (e, t)
            k += 1
    for e, mean in enumerate(_episode_means(out, IMAGE_CAMERA)):
        pixels = np.stack([image_pixels(e, t) for t in range(LENGTHS[e])]).reshape(-1, 3) / 255.0
        assert np.allclose(mean, pixels.mean(axis=0), atol=1e-9)  # from the pictures handed to the encoder

    # and the new video camera is a camera like any other: it can be re-encoded (here to av1, at least 32x32)
    again = tmp_path / "again"
    res = run_cli("videos", "reencode", str(out), "--codec", "av1", "--size", "32x32", "--out", str(again))
    assert res.returncode == 0, res.stderr
    assert check(again, deep=True) == []
    _same_except(_frames(again), got, {IMAGE_CAMERA, CAM})
