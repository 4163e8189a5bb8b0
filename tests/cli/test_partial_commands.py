"""The read-only and pixel commands on a partial download (#30): `info` and `stats` work and say what is
missing (a line; a field of `info --json`, a `missing_file` health row per kind); `view --save` and `convert` to
MCAP need the pixels of the episodes they show, so they name the absent file in one line, exit 2, nothing
written."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from openral_data.formats.lerobot_v3 import layout
from tests.support.inproc import run_inproc
from tests.support.lerobot_written import VIDEO_CAMERA
from tests.support.partial import NO_VIDEOS, first_data, lerobot_source, partial_copy


@pytest.fixture(scope="module")
def full(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return lerobot_source(tmp_path_factory.mktemp("partial"))


@pytest.fixture(scope="module")
def no_videos(full: Path) -> Path:
    return partial_copy(full, full.parent / "no-videos", NO_VIDEOS)


def test_info_says_what_is_missing(full: Path, no_videos: Path) -> None:
    run = run_inproc("info", str(no_videos))
    assert run.returncode == 0, run.stderr
    (line,) = [x for x in run.stdout.splitlines() if x.strip().startswith("missing")]
    assert f"videos/{VIDEO_CAMERA} 1 of 1 files (file-000.mp4); fetch them: hf download REPO_ID" in line
    doc = json.loads(run_inproc("info", str(no_videos), "--json").stdout)
    assert doc["missing"] == {
        "data": [],
        "videos": {VIDEO_CAMERA: [f"videos/{VIDEO_CAMERA}/chunk-000/file-000.mp4"]},
        "stats": False,
    }
    assert doc["episodes"] == 3 and doc["success_rate"] == pytest.approx(2 / 3)
    whole = run_inproc("info", str(full))
    assert (
        "missing" not in whole.stdout and json.loads(run_inproc("info", str(full), "--json").stdout)["missing"] is None
    )


def test_info_and_stats_without_data_and_stats_json(full: Path, tmp_path: Path) -> None:
    src = partial_copy(full, tmp_path / "src", (first_data(full), layout.STATS_PATH))
    doc = json.loads(run_inproc("info", str(src), "--json").stdout)
    assert doc["missing"] == {"data": [first_data(full)], "videos": {}, "stats": True}
    run = run_inproc("stats", str(src), "--format", "json")
    assert run.returncode == 0, run.stderr
    health = [(h["check"], h["detail"].split(":")[0]) for h in json.loads(run.stdout)["health"]]
    assert health == [("missing_file", "data")]


@pytest.mark.parametrize(
    "argv",
    [
        ["view", "{src}", "--save", "{out}.rrd"],
        ["convert", "{src}", "{out}"],
        ["replay", "{src}", "--mode", "policy", "--rskill", "recorded", "--out", "{out}"],
    ],
    ids=["view", "convert", "replay-policy"],
)
def test_pixel_commands_name_the_absent_file(no_videos: Path, tmp_path: Path, argv: list[str]) -> None:
    out = tmp_path / "out"
    run = run_inproc(*[a.format(src=no_videos, out=out) for a in argv])
    assert run.returncode == 2 and run.stderr.count("\n") == 1, run.stderr
    mp4 = no_videos / f"videos/{VIDEO_CAMERA}/chunk-000/file-000.mp4"
    assert run.stderr.startswith(f"error: {mp4}: {VIDEO_CAMERA}: missing, not downloaded"), run.stderr
    assert not out.exists() and not out.with_suffix(".rrd").exists()
