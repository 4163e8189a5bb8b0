"""Depth cameras in `browse`: lerobot's 12-bit HEVC depth video is not played by browsers, so the episode page
shows the frame at the cursor as a grey PNG the server decodes (nearer is brighter), labelled with its unit."""

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
from tests.support.lerobot_written import DEPTH_CAMERA, DEPTH_SHAPE, write_lerobot_dataset


@pytest.fixture(scope="module")
def depth_dataset(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("depth") / "ds"
    write_lerobot_dataset(root, True, depth_camera=True)
    return root


@pytest.fixture(scope="module")
def client(depth_dataset: Path) -> Iterator[TestClient]:
    catalogs = open_catalogs([str(depth_dataset)])
    with TestClient(create_app(catalogs), base_url="http://127.0.0.1") as c:
        yield c
    catalogs[0].close()


def test_depth_camera_is_marked_with_its_unit(client: TestClient) -> None:
    cams = {c["key"]: c for c in client.get("/api/d/0/episode/1").json()["cameras"]}
    assert cams[DEPTH_CAMERA]["depth"] == "mm" and cams["observation.images.cam"]["depth"] is None


def test_depth_frame_is_a_grey_ramp_near_bright(client: TestClient) -> None:
    keys = [c["key"] for c in client.get("/api/d/0/episode/1").json()["cameras"]]
    number, rgb = keys.index(DEPTH_CAMERA), keys.index("observation.images.cam")
    r = client.get(f"/d/0/depth/1/{number}/3")
    assert r.status_code == 200 and r.headers["content-type"] == "image/png"
    grey = np.asarray(Image.open(io.BytesIO(r.content)))
    assert grey.shape == DEPTH_SHAPE[:2]
    assert grey[:2, :2].max() == 0  # no return: black
    row = grey[10, 2:].astype(int)  # depth grows along x: brightness falls
    assert grey.max() == 255 and (np.diff(row) <= 0).all() and row[-1] < row[0]
    assert client.get(f"/d/0/depth/1/{number}/9").status_code == 404  # episode 1 has 9 frames: 0..8
    assert client.get(f"/d/0/depth/1/{rgb}/0").status_code == 404  # an RGB camera has no depth frames
    assert client.get("/d/0/depth/7/1/0").status_code == 404


def test_the_episode_page_draws_the_depth_frame(depth_dataset: Path, page: Any) -> None:
    server = Browser(open_catalogs([str(depth_dataset)]))
    server.start()
    try:
        page.goto(server.url + "d/0/episode/1")
        page.wait_for_selector("body[data-ready='1']")
        page.wait_for_function("() => document.querySelector('img.depth').naturalWidth > 0")
        assert page.get_attribute("img.depth", "data-camera") == DEPTH_CAMERA
        assert "(depth, mm" in (page.text_content(".cams") or "")
    finally:
        server.close()
