"""LeRobot -> MCAP of a dataset lerobot 0.6.1 wrote with a `dtype: image` camera and an
`observation.environment_state`: the image camera becomes a camera topic whose pictures decode to the source
pixels (png exact, jpeg close) and the environment state a `/environment_state` topic with the same values."""

from __future__ import annotations

import io
import json
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from tests.support.cli import run_cli
from tests.support.lerobot_written import ENV_NAMES, LENGTHS, env_state, image_pixels, write_lerobot_dataset
from tests.support.mcap import check_bag


@pytest.fixture(scope="module")
def source(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("images") / "lr"
    write_lerobot_dataset(root, True, image_camera=True, environment_state=True)
    return root


@pytest.mark.slow
@pytest.mark.parametrize("fmt", ["png", "jpeg"])
def test_image_camera_and_environment_state_exported(source: Path, tmp_path: Path, fmt: str) -> None:
    out = tmp_path / "bags"
    proc = run_cli("convert", str(source), str(out), "--image-format", fmt, "--json")
    assert proc.returncode == 0, proc.stderr
    doc = json.loads(proc.stdout)
    assert doc["not_exported"] == [] and doc["frames"] == sum(LENGTHS)
    for e, n in enumerate(LENGTHS):
        topics = check_bag(out / f"episode_{e:06d}")
        pictures = topics["/camera/wrist/image/compressed"]
        assert len(pictures) == n and len(topics["/camera/cam/image/compressed"]) == n
        for t, (_, msg) in enumerate(pictures):
            got = np.asarray(Image.open(io.BytesIO(bytes(msg.data))).convert("RGB"), dtype=np.int16)
            want = image_pixels(e, t).astype(np.int16)
            if fmt == "png":
                assert np.array_equal(got, want)
            else:
                assert np.abs(got - want).mean() < 4.0
        env = topics["/environment_state"]
        assert [d.label for d in env[0][1].layout.dim] == ["environment_state"]
        assert [list(msg.data) for _, msg in env] == [env_state(e, t).tolist() for t in range(n)]
        start = json.loads(topics["/openral/episode"][0][1].data)
        assert start["environment_state_names"] == ENV_NAMES
