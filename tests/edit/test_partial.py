"""Edits of a partial download (#30): an edit asks only for the files it copies. `features remove` of a camera
whose videos were never downloaded works and lerobot 0.6.1 loads the output frame-exact against the full source;
an edit that keeps a camera (or episodes) whose files are absent refuses in one line naming them, writing
nothing."""

from __future__ import annotations

from pathlib import Path

import pytest

from openral_data.doctor import check
from openral_data.errors import DatasetError
from openral_data.formats.lerobot_v3.missing import MissingFiles
from tests.support import lerobot_written as written
from tests.support.inproc import run_inproc
from tests.support.partial import NO_VIDEOS, first_data, first_video, lerobot_source, partial_copy
from tests.support.recorded import record_small


@pytest.fixture(scope="module")
def full(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return lerobot_source(tmp_path_factory.mktemp("partial"))


def test_features_remove_of_a_camera_never_downloaded(full: Path, tmp_path: Path) -> None:
    """`hf download --include 'meta/*' 'data/*'`, then drop the camera: the rest loads exactly as in the source."""
    src = partial_copy(full, tmp_path / "src", NO_VIDEOS)
    out = tmp_path / "out"
    res = run_inproc("features", "remove", str(src), "--feature", written.VIDEO_CAMERA, "--out", str(out))
    assert res.returncode == 0, res.stderr
    assert res.stdout.startswith(f"removed: {out}  episodes 3  frames {sum(written.LENGTHS)}")
    assert check(out, deep=True) == []
    want = written.loaded_episodes(full)
    for got, w in zip(written.loaded_episodes(out), want, strict=True):
        written.same_frames(got, [dict(f, cam=None) for f in w])


@pytest.mark.parametrize(
    "argv",
    [
        ["episodes", "delete", "{src}", "--episodes", "0", "--out", "{out}"],
        ["features", "remove", "{src}", "--feature", written.IMAGE_CAMERA, "--out", "{out}"],
        ["tasks", "rename", "{src}", "--from", "push the block", "--to", "push", "--out", "{out}"],
        ["stats", "recompute", "{src}", "--out", "{out}"],
        ["videos", "reencode", "{src}", "--codec", "h264", "--out", "{out}"],
    ],
    ids=lambda a: " ".join(a[:2]),
)
def test_an_edit_that_keeps_an_absent_camera_refuses_in_one_line(full: Path, tmp_path: Path, argv: list[str]) -> None:
    mp4 = first_video(full, written.VIDEO_CAMERA)
    src = partial_copy(full, tmp_path / "src", (mp4,))
    before = written.digest(src)
    out = tmp_path / "out"
    res = run_inproc(*[a.format(src=src, out=out) for a in argv])
    assert res.returncode == 2 and res.stderr.count("\n") == 1, res.stderr
    assert res.stderr.startswith(f"error: {src / mp4}: {written.VIDEO_CAMERA}: missing"), res.stderr
    assert "not downloaded" in res.stderr and "hf download" in res.stderr and "--include 'videos/" in res.stderr
    assert not out.exists() and written.digest(src) == before


def test_absent_data_files_refuse_only_the_edits_that_read_them(full: Path, tmp_path: Path) -> None:
    """lerobot writes all three episodes into one data file: without it every edit refuses, naming it."""
    src = partial_copy(full, tmp_path / "src", (first_data(full),))
    out = tmp_path / "out"
    res = run_inproc("episodes", "split", str(src), "--episodes", "1", "--out", str(out))
    assert res.returncode == 2 and res.stderr.count("\n") == 1, res.stderr
    assert res.stderr.startswith(f"error: {src / first_data(full)}: data: missing"), res.stderr
    assert "--include 'data/*'" in res.stderr and "drop that camera" not in res.stderr and not out.exists()


def test_our_recording_without_one_camera(tmp_path: Path) -> None:
    """A recording of ours without one camera's videos: removing that camera works, the other one is copied."""
    ds = record_small(tmp_path / "rec")
    cameras = sorted(p.name for p in (ds / "videos").iterdir())
    gone, kept = cameras[0], cameras[1:]
    src = partial_copy(ds, tmp_path / "src", (f"videos/{gone}",))
    out = tmp_path / "out"
    res = run_inproc("features", "remove", str(src), "--feature", gone, "--out", str(out))
    assert res.returncode == 0, res.stderr
    assert check(out, deep=True) == []
    assert sorted(p.name for p in (out / "videos").iterdir()) == kept
    refused = run_inproc("episodes", "delete", str(src), "--episodes", "0", "--out", str(tmp_path / "o2"))
    assert refused.returncode == 2 and f"drop that camera first: features remove {src} --feature" in refused.stderr


def test_only_the_episodes_written_are_asked_for(tmp_path: Path) -> None:
    """Deleting the episodes whose data file is absent works; keeping one of them is refused, naming the file."""
    gone = MissingFiles(tmp_path, data={"data/chunk-000/file-001.parquet": [2, 3]}, named_data=2)
    gone.need([0, 1], [], "episodes delete")
    with pytest.raises(DatasetError, match=r"file-001.parquet: data: missing, not downloaded, and x needs it") as exc:
        gone.need([0, 3], [], "x")
    assert exc.value.code == "dataset.incomplete"
