"""`convert SRC DST` of an RLDS / TFDS build folder through the array-source path: the values equal what the
`tfrecord` package's own reader returns for the same records (numbers exactly, JPEG/PNG pictures decoded by PIL
within video codec tolerance), the episode's language instruction is its task, reward and is_terminal its
outcome; lerobot 0.6.1 loads the output frame-exact against our decode, `doctor --deep` finds it healthy; RLDS
declares no frame rate, so a missing `--fps` is one line, exit 2, nothing written; `--workers` splits by shards."""

from __future__ import annotations

import io
import json
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow.parquet as pq
import pytest
from PIL import Image

from openral_data.replay.recorded import RecordedDataset
from tests.cli.test_json import parse
from tests.support.array_sources import converted_episodes, lerobot_matches_ours
from tests.support.inproc import run_inproc
from tests.support.rlds_written import ACTION, STATE, write_rlds

VIDEO_TOL = 6.0  # mean absolute pixel difference after h264 at 64x64 (smooth gradients)


@pytest.fixture(scope="module")
def built(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return write_rlds(tmp_path_factory.mktemp("rlds") / "toy_rlds" / "1.0.0", smooth=True)


def _records(folder: Path) -> list[dict[str, Any]]:
    """Every episode as the `tfrecord` package reads it, shard after shard."""
    from tfrecord.reader import tfrecord_loader

    out: list[dict[str, Any]] = []
    for shard in sorted(folder.glob("*.tfrecord-*")):
        out.extend(tfrecord_loader(str(shard), None))
    return out


def _pictures(encoded: list[bytes]) -> np.ndarray[Any, Any]:
    def one(data: bytes) -> np.ndarray[Any, Any]:
        with Image.open(io.BytesIO(bytes(data))) as img:
            return np.asarray(img.convert("RGB"))

    return np.stack([one(b) for b in encoded]).astype(np.float64)


def test_rlds_converts_with_the_default_mapping(built: Path, tmp_path: Path) -> None:
    out = tmp_path / "out"
    records = _records(built)
    tables = converted_episodes(built, out, len(records), "--fps", "5")
    ours = RecordedDataset(out)
    for e, (rec, rows) in enumerate(zip(records, tables, strict=True)):
        n = len(rec["steps/is_first"])
        state = np.asarray(rec["steps/observation/state"], np.float32).reshape(n, STATE)
        action = np.asarray(rec["steps/action"], np.float32).reshape(n, ACTION)
        assert rows.column("observation.state").to_pylist() == state.tolist()
        assert rows.column("action").to_pylist() == action.tolist()
        assert rows.column("next.reward").to_pylist() == np.asarray(rec["steps/reward"], np.float32).tolist()
        assert rows.column("next.success").to_pylist() == [bool(v) for v in rec["steps/is_terminal"]]
        frames = list(ours.frames(e))
        assert {f.task for f in frames} == {bytes(rec["steps/language_instruction"][0]).decode()}
        for name, key in (("image", "steps/observation/image"), ("wrist", "steps/observation/wrist_image")):
            got = np.stack([f.images[name] for f in frames]).astype(np.float64)
            assert np.abs(got - _pictures(rec[key])).mean() <= VIDEO_TOL, name
    lerobot_matches_ours(out, ours)
    doctor = run_inproc("doctor", str(out), "--deep")
    assert doctor.returncode == 0 and "healthy" in doctor.stdout, doctor.stdout + doctor.stderr


def test_rlds_without_fps_is_one_line_and_writes_nothing(built: Path, tmp_path: Path) -> None:
    out = tmp_path / "out"
    run = run_inproc("convert", str(built.parent), str(out))  # the dataset folder holding one version
    assert run.returncode == 2 and run.stderr.count("\n") == 1, run.stderr
    assert run.stderr.startswith("error: ") and ": fps: " in run.stderr and "--fps" in run.stderr
    assert not out.exists() and list(tmp_path.iterdir()) == []


def test_rlds_print_mapping_and_workers_by_shard(built: Path, tmp_path: Path) -> None:
    run = run_inproc("convert", str(built), "--print-mapping", "--json")
    assert run.returncode == 0, run.stderr
    doc = parse(run.stdout, "convert print-mapping")
    mapping = doc["mapping"]
    assert doc["layout"] == "rlds" and mapping["task_topic"] == "episode:language"
    assert mapping["cameras"] == {"image": "steps/observation/image", "wrist": "steps/observation/wrist_image"}
    assert mapping["state"]["topic"] == "steps/observation/state" and mapping["action"]["topic"] == "steps/action"
    assert mapping["reward"] == {"topic": "steps/reward"} and mapping["success"] == {"topic": "steps/is_terminal"}
    one, two = tmp_path / "one", tmp_path / "two"
    assert run_inproc("convert", str(built), str(one), "--fps", "5", "--codec", "h264").returncode == 0
    run = run_inproc("convert", str(built), str(two), "--fps", "5", "--codec", "h264", "--workers", "2", "--json")
    assert run.returncode == 0, run.stderr
    assert json.loads(run.stdout)["workers"] == 2  # two shards, two blocks
    for column in ("episode_index", "frame_index", "observation.state", "action", "next.success"):
        assert pq.read_table(two / "data").column(column) == pq.read_table(one / "data").column(column)
