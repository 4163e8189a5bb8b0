"""Segmentation masks of the MuJoCo tabletop scenes (`segmentation: true` on a camera): recorded losslessly as a
lerobot `dtype: image` feature of 16-bit PNGs and as MCAP mono16 images, read back with the real readers
(lerobot 0.6.1, rosbags, mcap) and compared with a second rollout of the same seed and actions rendered by the
same rig; the cube's id covers the red pixels of the colour frame; doctor, stats, view, episodes and
stats recompute accept the dataset, and an actions replay re-records the same masks."""

from __future__ import annotations

import json
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
import pytest

from openral_data.formats.lerobot_v3.masks import decode_mask, encode_mask, mask_stats
from tests.support.cli import run_cli
from tests.support.home import isolated_home
from tests.support.mcap import check_bag
from tests.support.mujoco import push_scene, record_push_variant, red_mask
from tests.support.rrd import verify
from tests.support.scenes import mock_scene, write_yaml

SEED, STEPS = 5, 8
FRONT = {"name": "front", "width": 96, "height": 96, "pos": [1.2, 0.0, 1.3], "lookat": [0.42, 0.0, 0.85]}
WRIST = {"name": "wrist", "width": 48, "height": 48, "mount": "wrist"}
MASKS = ("front_segmentation", "wrist_segmentation")


@dataclass
class Recorded:
    out: Path
    info: dict[str, Any]
    masks: list[dict[str, npt.NDArray[np.uint16]]]  # per row: the reference render of each mask
    rgb: list[dict[str, npt.NDArray[np.uint8]]]


@pytest.fixture(scope="module")
def recorded(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Recorded]:
    base = tmp_path_factory.mktemp("segmentation")
    with isolated_home(base / "home") as home:
        cameras = [{**FRONT, "segmentation": True}, {**WRIST, "segmentation": True}]
        rec = record_push_variant(home, "seg_push", {"cameras": cameras}, SEED, STEPS, base / "out")
        env = push_scene(rec.scene_file)
        masks, rgb = [], []
        try:
            obs = env.reset(SEED)
            for action in rec.actions:
                masks.append({k: obs.images[k] for k in MASKS})
                rgb.append({k: obs.images[k] for k in ("front", "wrist")})
                obs = env.step(action).observation
        finally:
            env.close()
        yield Recorded(rec.out, json.loads((rec.out / "meta/info.json").read_text()), masks, rgb)


def _ids(info: dict[str, Any], key: str) -> dict[str, int]:
    """name -> id of a mask feature."""
    return {name: int(i) for i, name in info["features"][key]["info"]["segmentation_ids"].items()}


@pytest.mark.slow
def test_masks_load_in_lerobot_equal_to_the_render_and_the_cube_covers_the_red_pixels(recorded: Recorded) -> None:
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    feats = recorded.info["features"]
    for cam, size in (("front", 96), ("wrist", 48)):
        f = feats[f"observation.images.{cam}_segmentation"]
        assert f["dtype"] == "image" and f["shape"] == [size, size, 1]
        assert f["info"]["is_segmentation_mask"] is True
        ids = _ids(recorded.info, f"observation.images.{cam}_segmentation")
        assert ids["background"] == 0 and {"cube", "table", "goal"} <= set(ids)
        assert f["info"]["intrinsics"] == feats[f"observation.images.{cam}"]["info"]["intrinsics"]
    ds = LeRobotDataset("local/seg", root=recorded.out, video_backend="pyav")
    assert len(ds) == STEPS
    cube = _ids(recorded.info, "observation.images.front_segmentation")["cube"]
    for row in range(STEPS):
        item = ds[row]
        for cam in MASKS:
            want = recorded.masks[row][cam]
            got = item[f"observation.images.{cam}"]
            assert tuple(got.shape) == (1, *want.shape)
            assert np.array_equal(got.numpy()[0], want.astype(np.float32)), (row, cam)
        red = red_mask(recorded.rgb[row]["front"])
        assert red.sum() >= 10
        mask = recorded.masks[row]["front_segmentation"]
        assert (mask[red] == cube).all()  # every red pixel is the cube's
        assert (mask == cube).sum() <= 1.5 * red.sum()  # and the cube's pixels are (nearly all) red
    assert len(np.unique(recorded.masks[0]["front_segmentation"])) >= 4  # not a blank mask


@pytest.mark.slow
def test_mcap_carries_mono16_masks_equal_to_the_render(recorded: Recorded, tmp_path: Path) -> None:
    (bag,) = sorted((recorded.out / "mcap").glob("episode_*"))
    msgs = check_bag(bag)
    for cam in MASKS:
        images = msgs[f"/camera/{cam}/segmentation/image_raw"]
        assert len(images) == STEPS
        for row, (_, msg) in enumerate(images):
            assert msg.encoding == "mono16" and msg.step == 2 * msg.width and msg.is_bigendian == 0
            got = np.frombuffer(bytes(msg.data), dtype="<u2").reshape(msg.height, msg.width)
            assert np.array_equal(got, recorded.masks[row][cam])
    (_, start), *_ = msgs["/openral/episode"]
    marker = json.loads(start.data)
    assert (
        marker["segmentation_cameras"]["front_segmentation"]
        == (recorded.info["features"]["observation.images.front_segmentation"]["info"]["segmentation_ids"])
    )
    assert "front_segmentation" not in marker["cameras"]
    # the dataset exported to MCAP carries the same masks
    res = run_cli("convert", str(recorded.out), str(tmp_path / "bags"))
    assert res.returncode == 0, res.stderr
    (exported,) = sorted((tmp_path / "bags").glob("episode_*"))
    images = check_bag(exported)["/camera/front_segmentation/segmentation/image_raw"]
    got = [np.frombuffer(bytes(m.data), dtype="<u2").reshape(m.height, m.width) for _, m in images]
    assert all(np.array_equal(g, r["front_segmentation"]) for g, r in zip(got, recorded.masks, strict=True))


@pytest.mark.slow
def test_doctor_stats_view_and_edits_accept_masks(recorded: Recorded, tmp_path: Path) -> None:
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    stats = json.loads((recorded.out / "meta/stats.json").read_text())["observation.images.front_segmentation"]
    want = mask_stats([r["front_segmentation"] for r in recorded.masks])
    assert stats["max"] == want["max"].tolist() and stats["count"] == [STEPS]
    assert stats["max"][0][0][0] == float(max(int(r["front_segmentation"].max()) for r in recorded.masks))
    doctor = run_cli("doctor", "--deep", str(recorded.out))
    assert doctor.returncode == 0 and doctor.stdout.strip().endswith("healthy"), doctor.stdout + doctor.stderr
    assert run_cli("stats", str(recorded.out)).returncode == 0
    view = run_cli("view", str(recorded.out), "--save", str(tmp_path / "ep.rrd"))
    assert view.returncode == 0, view.stderr
    verify(tmp_path / "ep.rrd")
    again = run_cli("stats", "recompute", str(recorded.out), "--out", str(tmp_path / "re"))
    assert again.returncode == 0, again.stderr
    restated = json.loads((tmp_path / "re/meta/stats.json").read_text())["observation.images.front_segmentation"]
    assert restated == stats
    split = run_cli("episodes", "split", str(recorded.out), "--episodes", "0", "--out", str(tmp_path / "s"))
    assert split.returncode == 0, split.stderr
    ds = LeRobotDataset("local/s", root=tmp_path / "s", video_backend="pyav")
    got = ds[STEPS - 1]["observation.images.wrist_segmentation"].numpy()[0]
    assert np.array_equal(got, recorded.masks[STEPS - 1]["wrist_segmentation"].astype(np.float32))
    # actions replay rebuilds the scene with its segmenting cameras: the re-recorded masks are the same
    replay = run_cli(
        "replay", str(recorded.out), "--out", str(tmp_path / "r"), "--record", str(tmp_path / "again"), "--json"
    )
    assert replay.returncode == 0, replay.stderr
    again = LeRobotDataset("local/again", root=tmp_path / "again", video_backend="pyav")
    for row in (0, STEPS - 1):
        got = again[row]["observation.images.front_segmentation"].numpy()[0]
        assert np.array_equal(got, recorded.masks[row]["front_segmentation"].astype(np.float32))
    # a mask is never turned into a (lossy) video
    res = run_cli(
        "videos", "encode-images", str(recorded.out), "--camera", "front_segmentation", "--out", str(tmp_path / "v")
    )
    assert res.returncode == 2 and "segmentation mask" in res.stderr.splitlines()[0]
    assert not (tmp_path / "v").exists()


def test_mask_png_round_trip_is_exact() -> None:
    mask = np.array([[0, 1, 2], [65535, 300, 7]], dtype=np.uint16)
    png = encode_mask(mask)
    back = decode_mask({"bytes": png, "path": None}, "t")
    assert back.dtype == np.uint16 and np.array_equal(back, mask)


def test_segmentation_is_refused_where_a_scene_cannot_render_it(project: Path) -> None:
    data = mock_scene(cameras=[("front", 32, 32), ("front_segmentation", 32, 32)])
    data["scene"]["cameras"][0]["segmentation"] = True
    path = write_yaml(project / "scenes/sim/dup_seg.yaml", data)
    res = run_cli("record", "--scene", str(path), "--rskill", "zero-mock", "--out", str(project / "d0"))
    assert res.returncode == 2 and "['front_segmentation']" in res.stderr.splitlines()[0]
    data = mock_scene(cameras=[("front", 32, 32)])
    data["scene"]["cameras"][0]["segmentation"] = True
    path = write_yaml(project / "scenes/sim/seg_mock.yaml", data)
    res = run_cli("record", "--scene", str(path), "--rskill", "zero-mock", "--out", str(project / "d1"))
    assert res.returncode == 2
    assert res.stderr.splitlines()[0] == (
        f"error: {path}: scene.cameras[0].segmentation: this scene type renders no segmentation"
    )
    assert not (project / "d0").exists() and not (project / "d1").exists()
