"""`doctor` on a partial download (#30): absent files are a warning with a stable code (`video.missing`,
`data.missing`, `stats.missing`) that names the `hf download` command fetching them, never a crash or an error;
`--deep` decodes what is there; `--repair` does not cut the dataset down to what was downloaded."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from openral_data.doctor import check
from openral_data.formats.lerobot_v3 import layout
from tests.support.inproc import run_inproc
from tests.support.lerobot_written import VIDEO_CAMERA, digest
from tests.support.partial import NO_VIDEOS, first_data, first_video, lerobot_source, partial_copy
from tests.support.recorded import record_small


@pytest.fixture(scope="module")
def full(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return lerobot_source(tmp_path_factory.mktemp("partial"))


def _findings(root: Path, *flags: str) -> tuple[int, list[dict[str, object]]]:
    run = run_inproc("doctor", str(root), "--json", *flags)
    assert "Traceback" not in run.stderr, run.stderr
    return run.returncode, json.loads(run.stdout)["findings"]


def test_no_videos_is_one_warning_per_camera(full: Path, tmp_path: Path) -> None:
    src = partial_copy(full, tmp_path / "src", NO_VIDEOS)
    code, found = _findings(src, "--deep")
    assert code == 0, found
    assert [(f["code"], f["severity"], f["where"]) for f in found] == [
        ("video.missing", "warning", f"videos/{VIDEO_CAMERA}")
    ]
    message = str(found[0]["message"])
    assert message.startswith("1 of 1 files (file-000.mp4) not downloaded, episode(s) [0, 1, 2]"), message
    assert f"hf download REPO_ID --repo-type dataset --include 'videos/{VIDEO_CAMERA}/*' --local-dir {src}" in message


def test_absent_data_file_is_a_warning_and_repair_cuts_nothing(full: Path, tmp_path: Path) -> None:
    src = partial_copy(full, tmp_path / "src", (first_data(full),))
    code, found = _findings(src)
    assert code == 0, found
    assert [(f["code"], f["severity"]) for f in found] == [("data.missing", "warning")], found
    assert "--include 'data/*'" in str(found[0]["message"])
    before = digest(src)
    run = run_inproc("doctor", str(src), "--repair")
    assert run.returncode == 1, run.stdout + run.stderr
    assert "refused  nothing rewritten: data: 1 of 1 file(s) not downloaded" in run.stdout, run.stdout
    assert {k: v for k, v in digest(src).items() if not k.startswith(".openral")} == before


def test_absent_stats_json_names_the_command(full: Path, tmp_path: Path) -> None:
    src = partial_copy(full, tmp_path / "src", (layout.STATS_PATH,))
    (f,) = [f for f in check(src) if f.code == "stats.missing"]
    assert f.severity == "warning" and "--include 'meta/stats.json'" in f.message


def test_our_recording_missing_one_mp4(tmp_path: Path) -> None:
    """Our own dataset (content digests kept) without one mp4: the missing file, not a changed digest; --repair
    leaves it as it is."""
    import shutil

    ds = record_small(tmp_path / "rec")
    src = shutil.copytree(ds, tmp_path / "src")
    key = sorted(p.name for p in (src / "videos").iterdir())[0]
    (src / first_video(src, key)).unlink()
    found = check(src, deep=True)
    assert [(f.code, f.severity, f.where) for f in found] == [("video.missing", "warning", f"videos/{key}")], found
    run = run_inproc("doctor", str(src), "--repair")
    assert run.returncode == 0 and "nothing to repair" in run.stdout, run.stdout + run.stderr
