"""`view` of a dataset lerobot 0.6.1 wrote with a `dtype: image` camera and an `observation.environment_state`:
the image camera is logged frame by frame (its PNGs decode to the source pixels) and the environment state as
one named series per dimension."""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from openral_data.viz.rerun_view import ViewOptions, run_view
from tests.support.lerobot_written import ENV_NAMES, LENGTHS, env_state, image_pixels, write_lerobot_dataset
from tests.support.rrd import verify
from tests.viz.test_rerun_view import column, rows_by_entity


@pytest.mark.slow
def test_view_image_camera_and_environment_state(tmp_path: Path) -> None:
    root = tmp_path / "lr"
    write_lerobot_dataset(root, True, image_camera=True, environment_state=True)
    episode, n = 1, LENGTHS[1]
    rrd = tmp_path / "ep.rrd"
    run_view(ViewOptions(root, episode=episode, save=rrd))
    verify(rrd)
    temporal, _ = rows_by_entity(rrd)
    expected = {"/cameras/cam", "/cameras/wrist"} | {f"/environment_state/{name}" for name in ENV_NAMES}
    assert {e: temporal[e] for e in expected} == dict.fromkeys(expected, n)
    blobs = column(rrd, "/cameras/wrist", "EncodedImage:blob")
    assert len(blobs) == n
    for t, blob in enumerate(blobs):
        assert isinstance(blob, list)
        data = bytes(blob)
        assert np.array_equal(np.asarray(Image.open(io.BytesIO(data)).convert("RGB")), image_pixels(episode, t))
    for i, name in enumerate(ENV_NAMES):
        values = column(rrd, f"/environment_state/{name}", "Scalars:scalars")
        assert values == [float(env_state(episode, t)[i]) for t in range(n)]
