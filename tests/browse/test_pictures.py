"""`dtype: image` features in `browse`: a camera stored as pictures (lerobot's `dtype: image`) and a segmentation
mask (16-bit object ids) are drawn on the server as the PNG of frame k (a mask in one colour per object,
background black), and the episode page's frame slider moves them (no video is needed to step through them)."""

from __future__ import annotations

import io
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from PIL import Image
from starlette.testclient import TestClient

from openral_data.browse import Browser, create_app, open_catalogs
from openral_data.formats.lerobot_v3 import LeRobotV3Writer
from openral_data.runtime.bridge import DatasetBridge
from openral_data.types import CameraShape, DatasetSchema, Observation
from tests.support.lerobot_written import IMAGE_CAMERA, image_pixels, write_lerobot_dataset

SIDE, LENGTHS = 32, [4, 5]


def mask(e: int, t: int) -> np.ndarray:
    """Object 1 a square moving right with t, object 7 a bar in episode 1 only; background 0."""
    ids = np.zeros((SIDE, SIDE), np.uint16)
    ids[4:8, t : t + 4] = 1
    if e == 1:
        ids[24:, :] = 7
    return ids


@pytest.fixture(scope="module")
def mask_dataset(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Our writer's segmentation stream (`segmentation: true` cameras of the MuJoCo scenes) beside an RGB camera."""
    root = tmp_path_factory.mktemp("masks") / "ds"
    ids = {"segmentation_ids": {"1": "cube", "7": "table"}}
    schema = DatasetSchema(
        fps=10,
        state_names=("s0",),
        action_names=("a0",),
        cameras={"cam": CameraShape(SIDE, SIDE), "seg": CameraShape(SIDE, SIDE, segmentation=True, info=ids)},
        robot_type="unit",
    )
    bridge = DatasetBridge(schema, [LeRobotV3Writer(root, schema)])
    for e, n in enumerate(LENGTHS):
        bridge.begin_episode(seed=e, initial_state={})
        for t in range(n):
            images = {"cam": np.full((SIDE, SIDE, 3), 20 * t, np.uint8), "seg": mask(e, t)}
            obs = Observation(images=images, state=np.array([t], np.float32), task="stack")
            bridge.add_step(obs, np.array([0.0], np.float32), reward=0.0, done=t == n - 1, success=False)
        bridge.end_episode(success=False)
    bridge.close()
    return root


def _client(root: Path) -> Iterator[TestClient]:
    catalogs = open_catalogs([str(root)])
    with TestClient(create_app(catalogs), base_url="http://127.0.0.1") as c:
        yield c
    catalogs[0].close()


def _png(client: TestClient, url: str) -> np.ndarray:
    r = client.get(url)
    assert r.status_code == 200 and r.headers["content-type"] == "image/png", (url, r.status_code)
    return np.asarray(Image.open(io.BytesIO(r.content)).convert("RGB"))


def test_a_mask_frame_is_its_objects_in_colour(mask_dataset: Path) -> None:
    for client in _client(mask_dataset):
        cams = client.get("/api/d/0/episode/1").json()["cameras"]
        [seg] = [c for c in cams if c.get("picture") is not None]
        assert (seg["key"], seg["kind"]) == ("observation.images.seg", "mask")
        colour: dict[int, tuple[int, ...]] = {}
        for t in (2, 3):  # every id in one colour of its own, the same in every frame; background black
            got, ids = _png(client, f"/d/0/picture/1/{seg['picture']}/{t}"), mask(1, t)
            for i in np.unique(ids):
                [one] = {tuple(int(v) for v in px) for px in got[ids == i]}
                assert colour.setdefault(int(i), one) == one
        assert colour[0] == (0, 0, 0) and min(colour[1]) >= 64 and colour[1] != colour[7]
        assert client.get(f"/d/0/picture/1/{seg['picture']}/5").status_code == 404  # episode 1: frames 0..4
        assert client.get("/d/0/picture/1/9/0").status_code == 404
        series = client.get("/api/d/0/episode/1/series").json()["series"]  # a 1-dim state: scalar cells
        assert [s["values"] for s in series if s["name"] == "s0"] == [[0.0, 1.0, 2.0, 3.0, 4.0]]


def test_an_image_camera_frame_is_its_picture(tmp_path: Path) -> None:
    root = tmp_path / "ds"
    write_lerobot_dataset(root, True, image_camera=True)
    for client in _client(root):
        [pic] = [c for c in client.get("/api/d/0/episode/2").json()["cameras"] if c.get("picture") is not None]
        assert (pic["key"], pic["kind"]) == (IMAGE_CAMERA, "image")
        assert np.array_equal(_png(client, f"/d/0/picture/2/{pic['picture']}/1"), image_pixels(2, 1))


def test_the_frame_slider_moves_the_mask(mask_dataset: Path, page: Any) -> None:
    server = Browser(open_catalogs([str(mask_dataset)]))
    server.start()
    try:
        page.goto(server.url + "d/0/episode/1")
        page.wait_for_selector("body[data-ready='1']")
        page.wait_for_function("() => document.querySelector('img.mask').naturalWidth > 0")
        page.eval_on_selector("#frame", "s => { s.value = '3'; s.dispatchEvent(new Event('input')); }")
        page.wait_for_function("() => document.querySelector('img.mask').src.endsWith('/3')")
        page.wait_for_function("() => document.querySelector('img.mask').complete")
        assert "segmentation mask" in (page.text_content(".cams") or "")
    finally:
        server.close()
