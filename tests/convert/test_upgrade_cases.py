"""The v2.x datasets lerobot 0.6.1's own converter gets wrong (tests/support/upgrade_cases.py), each shown going
wrong in lerobot's converter and right in `upgrade`: NEW is the upgrade of the same dataset without the defect
(file for file, or but for what the defect is about), it passes `doctor --deep`, and OLD stays untouched."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from tests.support.inproc import run_inproc
from tests.support.legacy_v2 import IMAGE_CAMERA, VIDEO_CAMERA
from tests.support.lerobot_written import digest, loaded_episodes, same_frames
from tests.support.real_datasets import REAL, copy_real, real_root
from tests.support.upgrade_cases import assert_loads_like_old, old_frames, reference, written

pytestmark = pytest.mark.slow  # each case also runs lerobot's converter


def _files(root: Path) -> dict[str, bytes]:
    return {str(p.relative_to(root)): p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()}


def _upgraded(old: Path, new: Path) -> Path:
    before = digest(old)
    res = run_inproc("upgrade", str(old), str(new))
    assert res.returncode == 0, res.stderr
    assert digest(old) == before
    doctor = run_inproc("doctor", "--deep", str(new))
    assert doctor.returncode == 0 and "healthy" in doctor.stdout, doctor.stdout
    return new


@pytest.fixture(scope="module")
def baseline(tmp_path_factory: pytest.TempPathFactory) -> dict[str, bytes]:
    """The upgrade of the dataset without any defect (as lerobot's converter writes it too: test_upgrade.py)."""
    work = tmp_path_factory.mktemp("baseline")
    return _files(_upgraded(written(work / "old", image=True), work / "new"))


def _case(tmp_path: Path, variant: str) -> tuple[Path, Path]:
    old = written(tmp_path / "old", variant, image=True)
    return old, _upgraded(old, tmp_path / "new")


def _stats(root: Path) -> dict[str, dict[str, list[float]]]:
    return json.loads((root / "meta/stats.json").read_text())  # type: ignore[no-any-return]


def test_cameras_with_null_names(tmp_path: Path, baseline: dict[str, bytes]) -> None:
    """lerobot issue #3786: the converter keeps `names: null` and lerobot's policy features then fail."""
    from lerobot.utils.feature_utils import dataset_to_policy_features

    old, new = _case(tmp_path, "camera_names_null")
    ref = json.loads((reference(old, tmp_path) / "meta/info.json").read_text())["features"]
    assert ref[VIDEO_CAMERA]["names"] is None
    with pytest.raises(TypeError):
        dataset_to_policy_features(ref)
    got = json.loads((new / "meta/info.json").read_text())["features"]
    for key in (VIDEO_CAMERA, IMAGE_CAMERA):
        assert got[key]["names"] == ["height", "width", "channels"]
    assert dataset_to_policy_features(got)[VIDEO_CAMERA].shape == (3, 32, 32)
    files = _files(new)
    assert {k: v for k, v in files.items() if k != "meta/info.json"} == {
        k: v for k, v in baseline.items() if k != "meta/info.json"
    }
    for g, w in zip(loaded_episodes(new), old_frames(old), strict=True):
        same_frames(g, w)


def test_v21_without_camera_stats(tmp_path: Path, baseline: dict[str, bytes]) -> None:
    """#3786: episodes_stats.jsonl without the cameras: lerobot's stats.json lacks them; ours has them computed."""
    old, new = _case(tmp_path, "without_camera_stats")
    assert VIDEO_CAMERA not in _stats(reference(old, tmp_path))
    want = json.loads(baseline["meta/stats.json"])
    got = _stats(new)
    for key, tol in ((IMAGE_CAMERA, 1e-5), (VIDEO_CAMERA, 6 / 255)):  # the video: decoded, not the source pixels
        for name in ("min", "max", "mean", "std"):
            assert np.allclose(got[key][name], want[key][name], rtol=1e-3, atol=tol), (key, name)
        assert got[key]["count"] == want[key]["count"]
    assert got["action"] == want["action"]  # what OLD had is kept as it was


def test_flat_camera_stats(tmp_path: Path, baseline: dict[str, bytes]) -> None:
    """Camera stats one value per channel: lerobot's aggregate_stats raises; ours takes them as (3, 1, 1)."""
    old, new = _case(tmp_path, "flat_camera_stats")
    with pytest.raises(ValueError, match=r"\(3,1,1\)"):
        reference(old, tmp_path)
    assert _files(new) == baseline


def test_info_without_total_chunks_and_total_videos(tmp_path: Path, baseline: dict[str, bytes]) -> None:
    old, new = _case(tmp_path, "without_info_keys")
    with pytest.raises(KeyError, match="total_chunks"):
        reference(old, tmp_path)
    assert _files(new) == baseline


def test_stale_totals_and_lengths(tmp_path: Path, baseline: dict[str, bytes]) -> None:
    """info.json's totals and an episode's `length` off: lerobot copies them (its len(dataset) is then wrong)."""
    old, new = _case(tmp_path, "stale_counts")
    ref = reference(old, tmp_path)
    assert json.loads((ref / "meta/info.json").read_text())["total_frames"] != 16
    assert _files(new) == baseline


def test_macos_resource_forks_beside_the_files(tmp_path: Path, baseline: dict[str, bytes]) -> None:
    """`._episode_000000.parquet` (a dataset copied off a Mac): lerobot's converter globs and reads it."""
    old, new = _case(tmp_path, "apple_double")
    with pytest.raises((pa.ArrowException, OSError)):  # pyarrow's own error for the garbage file
        reference(old, tmp_path)
    assert _files(new) == baseline


def test_a_subset_of_episodes_is_renumbered(tmp_path: Path) -> None:
    """Episodes 1 and 2 only (episode 0 deleted): lerobot's converter pairs episodes by position and refuses it;
    upgrade numbers them 0 and 1 (episode_index, index from 0, their stats computed again) and lerobot loads
    every frame of OLD's."""
    old, new = _case(tmp_path, "subset")
    from datasets.exceptions import DatasetGenerationError

    with pytest.raises(DatasetGenerationError) as refused:  # raised inside lerobot's generator
        reference(old, tmp_path)
    assert "Number of episodes is not the same" in str(refused.value.__cause__)
    got = loaded_episodes(new)  # asserts index == position and timestamp == frame_index / fps
    assert [len(e) for e in got] == [8, 3]
    for g, w in zip(got, old_frames(old), strict=True):
        same_frames(g, w)
    stats = _stats(new)
    assert stats["episode_index"]["max"] == [1] and stats["index"]["max"] == [10]


def test_wallclock_timestamps_are_put_on_the_frame_grid(tmp_path: Path) -> None:
    """Timestamps off t / fps: lerobot's converter converts them and its loader then fails; upgrade sets them to
    t / fps (where the video's frames are) and lerobot loads every frame of OLD's."""
    from lerobot.datasets.lerobot_dataset import LeRobotDataset
    from lerobot.datasets.video_utils import FrameTimestampError

    old, new = _case(tmp_path, "wallclock")
    ref = LeRobotDataset("local/ref", root=reference(old, tmp_path), video_backend="pyav")
    with pytest.raises(FrameTimestampError, match="tolerance"):
        ref[0]
    for g, w in zip(loaded_episodes(new), old_frames(old), strict=True):
        same_frames(g, w)


@pytest.mark.parametrize("name", [n for n, d in REAL.items() if d.version.startswith("v2")])
def test_real_v2_datasets(tmp_path: Path, name: str) -> None:
    """The real third-party v2.1 fixtures (tests/fixtures/lerobot/README.md), both refused or unloadable after
    lerobot's converter (G1: its only episode is 29; CR5: wall-clock timestamps): upgraded, they pass `doctor
    --deep` and lerobot loads OLD's frames from them (pixels of every 10th frame compared: AV1 at 640x480)."""
    if real_root(name) is None:
        pytest.skip(f"real fixture {name} is not present")
    old = copy_real(name, tmp_path)
    new = _upgraded(old, tmp_path / "new")
    assert assert_loads_like_old(old, new, every=10) == REAL[name].frames


def _own_script_v21(tmp_path: Path) -> Path:
    """lerobot 0.3.3's own v2.1 dataset, then written over as an author's own script writes v2.1
    (`upgrade_cases.custom_script`: no index/task_index, `{chunk_index}` templates, mp4v, wall-clock times)."""
    from tests.support.old_lerobot import write_old
    from tests.support.upgrade_cases import custom_script

    old = write_old("0.3.3", tmp_path / "old")
    custom_script(old)
    return old


def test_an_own_script_v21_is_made_loadable(tmp_path: Path) -> None:
    """Issue #45 item 6: lerobot's converter converts such a dataset and its loader then fails on it; upgrade
    declares and builds index/task_index (each frame's task: its episode's one task), puts the timestamps on
    the 1/fps grid saying by how much, and lerobot loads every frame of OLD's, pixels equal."""
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    old = _own_script_v21(tmp_path)
    ref = reference(old, tmp_path)
    with pytest.raises(KeyError, match="index"):  # the converted dataset lacks lerobot's `index` column
        LeRobotDataset("local/ref", root=ref, video_backend="pyav")[0]
    res = run_inproc("upgrade", str(old), str(tmp_path / "new"))
    assert res.returncode == 0, res.stderr
    assert "declaring lerobot's default feature(s) index, task_index" in res.stderr
    assert "timestamps put on the video's 1/fps grid" in res.stderr and "moved by up to 0.0" in res.stderr
    new = tmp_path / "new"
    doctor = run_inproc("doctor", "--deep", str(new))
    assert doctor.returncode == 0 and "healthy" in doctor.stdout, doctor.stdout
    got = loaded_episodes(new)  # index == position, timestamp == frame_index / fps
    for g, w in zip(got, old_frames(old), strict=True):
        same_frames(g, w)
    assert [f["task"] for f in got[1]] == ["lift the cube"] * len(got[1])


def test_an_own_script_v21_whose_episode_has_two_tasks_is_refused(tmp_path: Path) -> None:
    """Without a task_index column, an episode listing two tasks cannot say which frame did which: refused,
    naming the column and the episode; NEW absent."""
    old = _own_script_v21(tmp_path)
    rows = [json.loads(line) for line in (old / "meta/episodes.jsonl").read_text().splitlines()]
    rows[1]["tasks"] = ["push the block", "lift the cube"]
    (old / "meta/episodes.jsonl").write_text("".join(json.dumps(r) + "\n" for r in rows))
    res = run_inproc("upgrade", str(old), str(tmp_path / "new"))
    assert res.returncode == 2
    assert "column 'task_index' is missing, and episode 1 lists" in res.stderr, res.stderr
    assert not (tmp_path / "new").exists()


def test_the_real_cr5_written_by_its_own_script(tmp_path: Path) -> None:
    """The real CR5 fixture turned into what its authors' script wrote before it was cleaned (issue #45 item 6):
    upgraded, lerobot loads its first and last frames with OLD's state and the task, indices rebuilt."""
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    from tests.support.upgrade_cases import custom_script

    name = "v21_cr5_wallclock_timestamps_av1"
    if real_root(name) is None:
        pytest.skip(f"real fixture {name} is not present")
    old = copy_real(name, tmp_path)
    states = np.asarray(pq.read_table(next(old.glob("data/*/*.parquet"))).column("observation.state").to_pylist())
    custom_script(old)
    res = run_inproc("upgrade", str(old), str(tmp_path / "new"))
    assert res.returncode == 0, res.stderr
    moved = re.search(r"moved by up to ([0-9.]+) s", res.stderr)
    assert moved and 0.9 < float(moved.group(1)) < 1.1, res.stderr  # wall-clock: ~0.95 s off the 10 fps grid
    ds = LeRobotDataset("local/cr5", root=tmp_path / "new", video_backend="pyav")
    for i in (0, len(ds) - 1):
        item = ds[i]
        assert int(item["index"]) == i and int(item["frame_index"]) == i and int(item["task_index"]) == 0
        assert abs(float(item["timestamp"]) - i / 10) < 1e-6
        assert item["task"] == "put the banana on the plate"
        np.testing.assert_array_equal(item["observation.state"].numpy(), states[i].astype(np.float32))
        assert tuple(item["observation.images.top"].shape) == (3, 480, 640)
