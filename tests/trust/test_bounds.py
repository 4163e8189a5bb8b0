"""Class 5 of #29, unbounded inputs: every JSON we read goes through one bounded reader (regular file, size cap,
nesting depth cap, a cap on info.json's features), and an MCAP chunk is decompressed no further than it declares.
Each case exits 2 with one `error:` line (or is a doctor finding), never a traceback, a hang or a MemoryError."""

from __future__ import annotations

import json
import os
import shutil
import time
from pathlib import Path

import pytest

from openral_data.errors import BagError, ConfigError, DatasetError
from openral_data.formats.jsonfile import MAX_JSON_DEPTH, parse_json, read_json
from openral_data.formats.lerobot_v3 import layout
from openral_data.formats.lerobot_v3.digests import DIGESTS_PATH, REHASH_PATH
from openral_data.formats.lerobot_v3.info import MAX_FEATURES
from openral_data.formats.mcap.chunks import check_mcap
from openral_data.formats.rosbag1 import check_ros1
from openral_data.pipeline.state import read_marker
from tests.malformed.conftest import corpus_dataset  # noqa: F401  (the session's small recorded dataset)
from tests.support.bags import write_ros1
from tests.support.bounded import run_bounded
from tests.support.home import isolated_home
from tests.support.inproc import run_inproc
from tests.support.mcap_bomb import write_bomb, write_ros1_bomb

DEEP = b"[" * 200_000 + b"]" * 200_000


@pytest.fixture
def ds(tmp_path: Path, corpus_dataset: Path) -> Path:  # noqa: F811
    """A fresh copy of the session's small recorded dataset."""
    return Path(shutil.copytree(corpus_dataset, tmp_path / "ds"))


def _one_line(stderr: str, names: str) -> None:
    lines = [ln for ln in stderr.splitlines() if ln.strip()]
    assert "Traceback" not in stderr, stderr
    assert len(lines) == 1 and lines[0].startswith("error: ") and names in lines[0], stderr


def test_depth_is_capped_without_recursion() -> None:
    assert parse_json("[" * MAX_JSON_DEPTH + "]" * MAX_JSON_DEPTH) is not None
    for depth in (MAX_JSON_DEPTH + 1, 900, 200_000):
        with pytest.raises(ValueError, match="nested more than"):
            parse_json("[" * depth + "]" * depth)
    assert parse_json('{"a": "[[[[", "b": [1, {"c": "]]]"}]}') == {"a": "[[[[", "b": [1, {"c": "]]]"}]}


def test_size_is_capped(tmp_path: Path) -> None:
    path = tmp_path / "big.json"
    path.write_text(json.dumps(["x" * 100] * 100))
    with pytest.raises(DatasetError, match="larger than 1000 bytes"):
        read_json(path, limit=1000)


def test_info_json_to_dev_zero_is_refused(ds: Path) -> None:
    (ds / layout.INFO_PATH).unlink()
    (ds / layout.INFO_PATH).symlink_to("/dev/zero")
    for args in (("info", str(ds)), ("stats", str(ds))):
        run = run_bounded(*args)
        assert not run.timed_out, args
        assert run.returncode == 2, (args, run.stderr)
        _one_line(run.stderr, "info.json")


def test_too_many_features_are_refused(ds: Path) -> None:
    """The red team's info.json had 10**6 features (`info` printed them all, slowly); one past the cap is enough."""
    info = json.loads((ds / layout.INFO_PATH).read_text())
    info["features"].update({f"f{i}": {"dtype": "float32", "shape": [1]} for i in range(MAX_FEATURES + 1)})
    (ds / layout.INFO_PATH).write_text(json.dumps(info))
    run = run_inproc("info", str(ds))
    assert run.returncode == 2
    _one_line(run.stderr, f"features: more than {MAX_FEATURES} features")
    doctor = run_inproc("doctor", str(ds))
    assert doctor.returncode == 1 and "Traceback" not in doctor.stderr
    assert f"more than {MAX_FEATURES} features" in doctor.stdout + doctor.stderr


# (command, the file made 200,000 deep, what the one line or the finding names)
DEEP_CASES = [
    (("info",), layout.INFO_PATH, "info.json"),
    (("doctor",), layout.INFO_PATH, "info.json"),
    (("doctor",), layout.STATS_PATH, "stats.json"),
    (("doctor",), DIGESTS_PATH, "digests.json"),
    (("doctor",), layout.JOURNAL_PATH, "journal.json"),
    (("stats",), layout.OPENRAL_PATH, "openral.json"),
    (("record", "--resume", "--out"), layout.RECORD_PATH, "record.json"),
    (("record", "--resume", "--out"), REHASH_PATH, "rehash.json"),
    (("record", "--resume", "--out"), layout.IMAGE_HIST_PATH, "image_hist.json"),
]


@pytest.mark.parametrize(("command", "rel", "names"), DEEP_CASES, ids=[f"{c[0]}-{r}" for c, r, _ in DEEP_CASES])
def test_deep_json_is_refused(
    command: tuple[str, ...],
    rel: str,
    names: str,
    corpus_dataset: Path,  # noqa: F811
    ds: Path,
) -> None:
    (ds / rel).parent.mkdir(parents=True, exist_ok=True)
    (ds / rel).write_bytes(DEEP)
    with isolated_home(corpus_dataset.parent):  # the project it was recorded in: --resume finds its manifests
        run = run_inproc(*command, str(ds))
    assert "Traceback" not in run.stderr, run.stderr
    if command[0] == "doctor":  # a finding naming the file, exit 1
        assert run.returncode == 1, run.stdout + run.stderr
        assert names in run.stdout + run.stderr and "nested more than" in run.stdout + run.stderr
    else:
        assert run.returncode == 2, run.stderr
        _one_line(run.stderr, names)


def test_deep_image_hist_is_ignored_by_edits(tmp_path: Path, ds: Path) -> None:
    """An edit only uses the writer's histograms when they are sound; deep ones are not: stats are merged."""
    (ds / layout.IMAGE_HIST_PATH).write_bytes(DEEP)
    run = run_inproc("episodes", "merge", str(ds), str(ds), "--out", str(tmp_path / "out"))
    assert run.returncode == 0 and "Traceback" not in run.stderr, run.stderr


def test_deep_pipeline_marker_is_refused(tmp_path: Path) -> None:
    marker = tmp_path / ".done.json"
    marker.write_bytes(DEEP)
    with pytest.raises(ConfigError, match="nested more than"):
        read_marker(marker)


def test_zstd_bomb_chunk_is_refused_before_decompressing(tmp_path: Path) -> None:
    bag = write_bomb(tmp_path / "bomb.mcap", expands_to=1 << 30)
    assert bag.stat().st_size < 200_000
    t0 = time.monotonic()
    with pytest.raises(BagError, match="expanding past its declared"):
        check_mcap(bag)
    assert time.monotonic() - t0 < 5


@pytest.mark.parametrize("command", ["convert", "view"])
def test_zstd_bomb_bag_exits_2(command: str, tmp_path: Path) -> None:
    """A 4 GiB bomb in a ~130 KB bag, refused before any reader decompresses it: before the bound, `convert`
    died of a MemoryError (3 GiB allowed here) and `view` handed it to rerun's loader and said it was saved."""
    bag = write_bomb(tmp_path / "bomb.mcap", expands_to=4 << 30)
    out = tmp_path / ("out" if command == "convert" else "out.rrd")
    run = (
        run_bounded(command, str(bag), str(out))
        if command == "convert"
        else run_bounded(command, str(bag), "--save", str(out))
    )
    assert not run.timed_out
    assert run.returncode == 2, run.stderr
    _one_line(run.stderr, "bomb.mcap: chunk: ")
    assert not out.exists()


def test_honest_zstd_bags_pass(tmp_path: Path) -> None:
    bag = write_bomb(tmp_path / "fine.mcap", expands_to=1 << 20, honest=True)
    check_mcap(bag)
    os.truncate(bag, bag.stat().st_size - 20)  # truncated: left to the reader, which says so
    check_mcap(bag)


def test_ros1_bz2_chunk_expanding_past_its_declared_size_is_refused(tmp_path: Path) -> None:
    """ROS 1 bags: rosbags decompresses a chunk whole, whatever its header declares; `convert` now walks the
    records first, as for MCAP. A real bag (rosbags' writer) is fine; with its chunk's size field lowered, it is
    refused in one line."""
    honest = write_ros1_bomb(tmp_path / "fine.bag", expands_to=4 << 20, honest=True)
    check_ros1(honest)
    bag = write_ros1_bomb(tmp_path / "bomb.bag", expands_to=4 << 20)
    with pytest.raises(BagError, match="a bz2 chunk expanding past its declared 1000 bytes"):
        check_ros1(bag)
    run = run_inproc("convert", str(bag), str(tmp_path / "out"))
    assert run.returncode == 2, run.stderr
    _one_line(run.stderr, "bomb.bag: chunk: ")
    assert not (tmp_path / "out").exists()


def test_our_ros1_bags_pass(tmp_path: Path) -> None:
    check_ros1(write_ros1(tmp_path / "plain.bag", duration_ms=200))
