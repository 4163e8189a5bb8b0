"""A dataset shaped like lerobot/pusht (camera key `observation.image`, names in lerobot's `{"motors": [...]}`
form), written by lerobot 0.6.1: every reading command finds its camera and its dimension names.

`features.camera_keys` names the camera `image`; `features.dim_names` reads `x`, `y`."""

from __future__ import annotations

import io
import json
from pathlib import Path

import numpy as np
import pytest
from PIL import Image
from rerun.chunk import RrdReader

from openral_data.formats.lerobot_v3.encoder import VideoSettings
from openral_data.formats.lerobot_v3.features import build_features, camera_keys, dim_names, writer_camera_keys
from openral_data.replay import ReplayOptions, replay
from openral_data.types import CameraShape, DatasetSchema
from openral_data.viz.rerun_view import ViewOptions, run_view
from tests.support.cli import run_cli
from tests.support.mcap import check_bag
from tests.support.pusht_like import CAMERA_KEY, LENGTHS, NAMES, TASK, grey, write_pusht_like


@pytest.fixture(scope="module")
def pusht(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("pusht") / "pusht_like"
    write_pusht_like(root)
    return root


def test_camera_keys_and_dim_names() -> None:
    features = {
        "observation.images.top": {"dtype": "video"},
        "observation.image": {"dtype": "image"},
        "observation.images_image": {"dtype": "video"},  # would be named `images_image`: no clash
        "observation.state": {"dtype": "float32", "shape": [2]},
        "observation.images.image": {"dtype": "video"},  # `image` is taken by observation.image
    }
    assert camera_keys(features) == {
        "top": "observation.images.top",
        "image": "observation.image",
        "images_image": "observation.images_image",
        "observation_images_image": "observation.images.image",
    }
    assert dim_names({"shape": [2], "names": {"motors": ["a", "b"]}}, "k") == ["a", "b"]
    assert dim_names({"shape": [2], "names": ["a", "b"]}, "k") == ["a", "b"]
    assert dim_names({"shape": [3], "names": ["a", "b"]}, "k") == ["k_0", "k_1", "k_2"]  # names every dim or none
    assert dim_names({"shape": [2], "names": None}, "state") == ["state_0", "state_1"]


def test_the_writer_keeps_a_sources_camera_key() -> None:
    features = {CAMERA_KEY: {"dtype": "video"}, "observation.images.top": {"dtype": "video"}}
    assert writer_camera_keys(["image", "top", "side"], features) == {
        "image": CAMERA_KEY,
        "top": "observation.images.top",
        "side": "observation.images.side",  # not in the features: our own layout
    }
    assert writer_camera_keys(["image"]) == {"image": "observation.images.image"}  # recording: our layout
    schema = DatasetSchema(10, ("x", "y"), ("x", "y"), {"image": CameraShape(32, 32)}, "2d pointer")
    built = build_features(schema, VideoSettings(), keys=writer_camera_keys(schema.cameras, features))
    assert built[CAMERA_KEY]["dtype"] == "video" and "observation.images.image" not in built
    assert "observation.images.image" in build_features(schema, VideoSettings())


@pytest.mark.slow
def test_info_doctor_and_stats(pusht: Path) -> None:
    info = json.loads(run_cli("info", str(pusht), "--json").stdout)
    assert info["cameras"] == [CAMERA_KEY] and info["successes"] == 1 and info["episodes"] == len(LENGTHS)
    doctor = run_cli("doctor", str(pusht), "--deep")
    assert doctor.returncode == 0 and doctor.stdout.strip() == f"{pusht}: healthy", doctor.stdout + doctor.stderr
    proc = run_cli("stats", str(pusht), "--format", "json")
    assert proc.returncode == 0, proc.stderr
    dims = json.loads(proc.stdout)["dimensions"]
    for feature in ("observation.state", "action"):
        assert [d["name"] for d in dims if d["feature"] == feature] == NAMES


@pytest.mark.slow
def test_convert_exports_the_camera(pusht: Path, tmp_path: Path) -> None:
    out = tmp_path / "bags"
    proc = run_cli("convert", str(pusht), str(out), "--image-format", "png", "--json")
    assert proc.returncode == 0, proc.stderr
    assert json.loads(proc.stdout)["not_exported"] == []
    for e, n in enumerate(LENGTHS):
        topics = check_bag(out / f"episode_{e:06d}")
        pictures = topics["/camera/image/image/compressed"]
        assert len(pictures) == n
        for t, (_, msg) in enumerate(pictures):
            got = np.asarray(Image.open(io.BytesIO(bytes(msg.data))).convert("RGB"), dtype=np.int16)
            assert np.abs(got - grey(t)).max() <= 3, (e, t)  # h264 round trip of a flat grey
        assert list(topics["/joint_states"][0][1].name) == NAMES
        assert topics["/task"][0][1].data == TASK


@pytest.mark.slow
def test_view_names_the_camera_and_the_dimensions(pusht: Path, tmp_path: Path) -> None:
    rrd = tmp_path / "v.rrd"
    run_view(ViewOptions(pusht, episode=1, save=rrd))
    paths = {c.entity_path for c in RrdReader(rrd).stream()}
    assert {"/cameras/image", "/state/x", "/state/y", "/action/x", "/action/y"} <= paths


@pytest.mark.slow
def test_policy_mode_sees_the_camera_and_names_the_dimensions(pusht: Path, tmp_path: Path) -> None:
    summary = replay(ReplayOptions(pusht, mode="policy", rskill="recorded", out=tmp_path / "res"))
    assert summary.summary["mode"] == "policy"
    assert summary.summary["action_names"] == NAMES and list(summary.summary["action_mae"]) == NAMES
    assert summary.summary["steps"] == sum(LENGTHS) and summary.summary["action_mae_mean"] == 0.0
    assert [o.success_recorded for o in summary.episodes] == [True, False]
