"""Quality, the rest of issue 33: `dtype: image` cameras measured like video cameras (a black span planted in
lerobot-written PNG cells is found frame-exactly), `info --json` and `info`'s text giving the same flagged counts,
`quality --threshold NAME=VALUE` (and its one-line refusals), and the Python face `openral_data.quality`."""

from __future__ import annotations

import io
import json
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.compute as pc
import pyarrow.parquet as pq
import pytest
from PIL import Image

import openral_data
from openral_data.metrics.quality import Thresholds
from tests.support import quality as q
from tests.support.curate import refused
from tests.support.inproc import run_inproc
from tests.support.lerobot_written import IMAGE_CAMERA, IMAGE_SHAPE, VIDEO_CAMERA, write_lerobot_dataset
from tests.support.metrics import data_file, rewrite_parquet

N = 40
BLACK = range(2, 6)  # episode 1's image-camera frames 2..5 black


@pytest.fixture(autouse=True)
def _xdg(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))  # a lerobot dataset's table goes there


def _idle_dataset(root: Path) -> Path:
    return q.idle_middle(root, N)  # the middle episode idle for 30 of 40 frames


def _ok(*args: str) -> str:
    done = run_inproc(*args)
    assert done.returncode == 0, done.stderr
    return done.stdout


def _black_png() -> bytes:
    buf = io.BytesIO()
    Image.fromarray(np.zeros(IMAGE_SHAPE, dtype=np.uint8)).save(buf, format="PNG")
    return buf.getvalue()


def test_image_camera_black_span_found_frame_exactly(tmp_path: Path) -> None:
    root = tmp_path / "lerobot"
    write_lerobot_dataset(root, with_success=True, image_camera=True)
    path = data_file(root)
    table = pq.read_table(path)
    cells = table.column(IMAGE_CAMERA).to_pylist()
    ep, frame = table.column("episode_index").to_pylist(), table.column("frame_index").to_pylist()
    for i in range(len(cells)):
        if ep[i] == 1 and frame[i] in BLACK:
            cells[i] = {**cells[i], "bytes": _black_png()}
    column = pa.array(cells, type=table.schema.field(IMAGE_CAMERA).type)
    rewrite_parquet(path, table.set_column(table.schema.get_field_index(IMAGE_CAMERA), IMAGE_CAMERA, column))
    got = openral_data.quality(root, stride=1)
    samples = pq.read_table(got.paths.camera_frames)
    wrist = samples.filter(pc.equal(samples["camera"], IMAGE_CAMERA))
    assert wrist.num_rows == 6 + 9 + 4  # every frame of every episode sampled
    black = wrist.filter(wrist["black"]).select(["episode_index", "frame_index"]).to_pylist()
    assert black == [{"episode_index": 1, "frame_index": t} for t in BLACK]
    rows = got.table.to_pylist()
    assert f"{IMAGE_CAMERA}:black" in rows[1]["camera_flags"]
    assert f"{IMAGE_CAMERA}:black" not in rows[0]["camera_flags"] + rows[2]["camera_flags"]
    assert samples.filter(pc.equal(samples["camera"], VIDEO_CAMERA)).num_rows == 19  # the video camera as before


def test_info_text_and_json_give_the_same_counts(tmp_path: Path) -> None:
    root = _idle_dataset(tmp_path / "ds")
    assert json.loads(_ok("info", str(root), "--json"))["quality"] is None
    _ok("quality", str(root))
    counts = json.loads(_ok("info", str(root), "--json"))["quality"]
    assert (counts["episodes"], counts["flagged"], counts["idle"], counts["jerky"], counts["gap"]) == (3, 1, 1, 0, 0)
    assert "quality       1 of 3 episodes flagged (idle 1)" in _ok("info", str(root))


def test_threshold_options_change_the_flags(tmp_path: Path) -> None:
    root = _idle_dataset(tmp_path / "ds")
    default = json.loads(_ok("quality", str(root), "--format", "json"))["quality"][0]
    assert default["idle"] == 1  # 30 of 40 frames idle: 0.75 >= 0.5
    looser = json.loads(
        _ok("quality", str(root), "--threshold", "idle-flag=0.9", "--threshold", "jerk_step=0.5", "--format", "json")
    )["quality"][0]
    assert (looser["idle"], looser["jerky"], looser["flagged"]) == (0, 0, 0)
    for pair, says in [
        ("idle_flag", "is not NAME=VALUE"),
        ("nope=1", "is not NAME=VALUE with NAME one of idle_speed, idle_flag"),
        ("idle_speed=fast", "idle_speed: 'fast' is not a number"),
        ("chatter_min_toggles=2.5", "chatter_min_toggles: '2.5' is not an integer"),
        ("idle_speed=-1", "idle_speed: '-1' must be a finite number >= 0"),
        ("blur_var=nan", "blur_var: 'nan' must be a finite number >= 0"),
    ]:
        assert says in refused("quality", str(root), "--threshold", pair)


def test_python_api(tmp_path: Path) -> None:
    root = _idle_dataset(tmp_path / "ds")
    got = openral_data.quality(root)
    assert got.computed and [r["idle"] for r in got.table.to_pylist()] == [False, True, False]
    assert not openral_data.quality(str(root)).computed  # cached
    loose = openral_data.quality(root, thresholds=Thresholds(idle_flag=0.9))
    assert loose.computed and not any(r["idle"] for r in loose.table.to_pylist())
    assert "quality" in openral_data.__all__ and "Thresholds" in openral_data.__all__
