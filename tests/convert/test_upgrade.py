"""`openral-data upgrade OLD NEW`: a LeRobot v2.0/v2.1 dataset written as v3.0 by lerobot 0.6.1's own converter.

Where lerobot's converter works (a v2.1 dataset as lerobot wrote it), NEW is what it writes, file for file, and
lerobot loads NEW frame-exact against OLD's frames; a v2.0 dataset (no per-episode statistics) gets them
computed as lerobot computes them; NEW passes `doctor --deep` and opens in `info`/`stats`; OLD is never written;
bad input is one line, exit 2, NEW absent.
"""

from __future__ import annotations

import json
import shutil
import sys
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest

from tests.support.inproc import run_inproc
from tests.support.legacy_v2 import LENGTHS, write_v2
from tests.support.lerobot_written import digest, loaded_episodes, same_frames
from tests.support.upgrade_cases import old_frames, reference


def _files(root: Path) -> dict[str, bytes]:
    return {str(p.relative_to(root)): p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()}


def _upgrade(old: Path, new: Path) -> None:
    res = run_inproc("upgrade", str(old), str(new))
    assert res.returncode == 0, res.stderr
    assert f"upgraded: {new}" in res.stdout


@pytest.fixture(scope="module")
def v21(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """A v2.1 dataset (a video and an image camera) and its upgrade."""
    work = tmp_path_factory.mktemp("v21")
    old = write_v2(work / "old", version="v2.1", image=True)
    before = digest(old)
    _upgrade(old, work / "new")
    assert digest(old) == before  # OLD is only read
    return old, work / "new"


@pytest.mark.slow
def test_same_files_as_lerobots_converter(v21: tuple[Path, Path], tmp_path: Path) -> None:
    old, new = v21
    ref = reference(old, tmp_path)
    assert _files(new) == _files(ref)  # info, tasks, episodes (stats included), stats.json, data, videos


@pytest.mark.slow
def test_lerobot_loads_it_frame_exact(v21: tuple[Path, Path]) -> None:
    old, new = v21
    got, want = loaded_episodes(new), old_frames(old)
    assert [len(e) for e in got] == list(LENGTHS)
    for g, w in zip(got, want, strict=True):
        same_frames(g, w)


def test_doctor_info_and_stats_open_it(v21: tuple[Path, Path]) -> None:
    _, new = v21
    doctor = run_inproc("doctor", "--deep", str(new))
    assert doctor.returncode == 0 and "healthy" in doctor.stdout, doctor.stdout + doctor.stderr
    info = run_inproc("info", str(new))
    assert info.returncode == 0 and f"frames        {sum(LENGTHS)}" in info.stdout, info.stdout + info.stderr
    stats = run_inproc("stats", str(new), "--format", "json")
    assert stats.returncode == 0, stats.stderr


def test_stages_are_shown_and_q_hides_them(tmp_path: Path) -> None:
    old = write_v2(tmp_path / "old", video=False)
    res = run_inproc("upgrade", str(old), str(tmp_path / "new"))
    assert res.returncode == 0, res.stderr
    stages = [line for line in res.stderr.splitlines() if line.startswith("upgrade: ")]
    assert [s.split(": ", 1)[1].split(" ", 1)[0] for s in stages] == [
        "read",
        "converting",
        "converting",
        "concatenating",
        "writing",
    ]
    assert "it/s" not in res.stderr  # lerobot's own progress bars are not shown
    quiet = run_inproc("-q", "upgrade", str(old), str(tmp_path / "new2"))
    assert quiet.returncode == 0 and quiet.stderr == "", quiet.stderr


@pytest.mark.slow
def test_v20_gets_per_episode_stats_as_lerobot_computes_them(tmp_path: Path) -> None:
    """v2.0 has no episodes_stats.jsonl (lerobot's converter needs it): every episode's statistics are computed
    with lerobot's compute_episode_stats; they match what the v2.1 dataset of the same frames stores (the video's
    within its compression error), and lerobot loads the result frame-exact."""
    from lerobot.datasets.compute_stats import compute_episode_stats

    old20 = write_v2(tmp_path / "old20", version="v2.0", image=True)
    old21 = write_v2(tmp_path / "old21", version="v2.1", image=True)
    res = run_inproc("upgrade", str(old20), str(tmp_path / "new20"))
    assert res.returncode == 0, res.stderr
    assert "stats computed" in res.stdout and "observation.images.cam" in res.stdout
    _upgrade(old21, tmp_path / "new21")
    ep20 = pq.read_table(tmp_path / "new20/meta/episodes/chunk-000/file-000.parquet").to_pylist()
    ep21 = pq.read_table(tmp_path / "new21/meta/episodes/chunk-000/file-000.parquet").to_pylist()
    for a, b in zip(ep20, ep21, strict=True):
        for column, value in b.items():
            if column.startswith("stats/"):
                tol = 6 / 255 if "images.cam" in column else 1e-5
                # lerobot's float32 running sums against the fixture's float64 ones: std agrees to ~1e-4
                assert np.allclose(np.asarray(a[column], float), np.asarray(value, float), rtol=1e-3, atol=tol), column
    # quantiles too (v2.1 stores none): lerobot's own function over the same numbers
    first = pq.read_table(old20 / "data/chunk-000/episode_000000.parquet")
    state = np.stack(first.column("observation.state").to_pylist()).astype(np.float32)
    want = compute_episode_stats({"observation.state": state}, {"observation.state": {"dtype": "float32"}})
    assert np.allclose(ep20[0]["stats/observation.state/q90"], want["observation.state"]["q90"])
    stats = json.loads((tmp_path / "new20/meta/stats.json").read_text())
    assert {"observation.images.cam", "observation.images.wrist", "action"} <= stats.keys()
    got = loaded_episodes(tmp_path / "new20")
    for g, w in zip(got, old_frames(old20), strict=True):
        same_frames(g, w)


def test_a_repo_id_in_lerobots_cache(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("HF_LEROBOT_HOME", str(tmp_path / "cache"))
    write_v2(tmp_path / "cache" / "someone" / "koch_test", video=False)
    _upgrade(Path("someone/koch_test"), tmp_path / "new")
    assert json.loads((tmp_path / "new/meta/info.json").read_text())["codebase_version"] == "v3.0"


# -- bad input: one line, exit 2, NEW absent, OLD untouched -----------------------------------------------------


def _refused(old: Path, new: Path, *needles: str) -> None:
    before = digest(old) if old.is_dir() else None
    res = run_inproc("upgrade", str(old), str(new))
    assert res.returncode == 2, res.stdout + res.stderr
    lines = [line for line in res.stderr.strip().splitlines() if not line.startswith("upgrade: ")]  # the stages
    assert len(lines) == 1 and lines[-1].startswith("error: "), res.stderr
    for needle in needles:
        assert needle in lines[-1], lines[-1]
    assert not new.exists() or not any(new.iterdir())
    assert not [p for p in new.parent.iterdir() if ".partial-" in p.name]
    if before is not None:
        assert digest(old) == before


@pytest.fixture
def small(tmp_path: Path) -> Path:
    return write_v2(tmp_path / "old", video=True)


def test_not_a_dataset(tmp_path: Path) -> None:
    (tmp_path / "old").mkdir()
    _refused(tmp_path / "old", tmp_path / "new", "info.json: missing")


def test_a_v3_dataset_is_already_v3(small: Path, tmp_path: Path) -> None:
    _upgrade(small, tmp_path / "v3")
    _refused(tmp_path / "v3", tmp_path / "new", "already v3.0")


def test_another_version(small: Path, tmp_path: Path) -> None:
    info = json.loads((small / "meta/info.json").read_text())
    (small / "meta/info.json").write_text(json.dumps({**info, "codebase_version": "v1.6"}))
    _refused(small, tmp_path / "new", "codebase_version", "v1.6")


@pytest.mark.parametrize(("name", "line"), [("episodes.jsonl", 4), ("tasks.jsonl", 3), ("episodes_stats.jsonl", 4)])
def test_a_broken_jsonl_line(small: Path, tmp_path: Path, name: str, line: int) -> None:
    path = small / "meta" / name
    path.write_text(path.read_text() + '{"episode_index": 3, "len\n')
    _refused(small, tmp_path / "new", f"{name}: line {line}: invalid JSON")


def test_a_missing_data_file(small: Path, tmp_path: Path) -> None:
    (small / "data/chunk-000/episode_000001.parquet").unlink()
    _refused(small, tmp_path / "new", "episode_000001.parquet: missing (episode 1)")


def test_a_missing_video(small: Path, tmp_path: Path) -> None:
    (small / "videos/chunk-000/observation.images.cam/episode_000002.mp4").unlink()
    _refused(small, tmp_path / "new", "episode_000002.mp4: missing (episode 2)")


def test_a_video_shorter_than_its_episode(small: Path, tmp_path: Path) -> None:
    """lerobot's converter concatenates it as it is; its loader then fails on the episode's last frames."""
    shutil.copyfile(
        small / "videos/chunk-000/observation.images.cam/episode_000002.mp4",
        small / "videos/chunk-000/observation.images.cam/episode_000001.mp4",
    )  # 3 frames for an episode of 8
    _refused(small, tmp_path / "new", "episode_000001.mp4: 3 frames, but episode 1 has 8")


def test_a_garbage_video(small: Path, tmp_path: Path) -> None:
    (small / "videos/chunk-000/observation.images.cam/episode_000001.mp4").write_bytes(b"not a video")
    _refused(small, tmp_path / "new", "episode_000001.mp4: not a readable video")


def test_a_garbage_data_file(small: Path, tmp_path: Path) -> None:
    (small / "data/chunk-000/episode_000001.parquet").write_bytes(b"not parquet")
    _refused(small, tmp_path / "new", "episode_000001.parquet: unreadable parquet")


def test_a_path_template_leading_out(small: Path, tmp_path: Path) -> None:
    info = json.loads((small / "meta/info.json").read_text())
    info["data_path"] = "../../{episode_index}.parquet"
    (small / "meta/info.json").write_text(json.dumps(info))
    _refused(small, tmp_path / "new", "data_path", "leads outside")


def test_new_exists(small: Path, tmp_path: Path) -> None:
    (tmp_path / "new").mkdir()
    (tmp_path / "new" / "keep.txt").write_text("mine")
    res = run_inproc("upgrade", str(small), str(tmp_path / "new"))
    assert res.returncode == 2 and "exists and is not empty" in res.stderr
    assert (tmp_path / "new" / "keep.txt").read_text() == "mine"


def test_new_inside_old(small: Path) -> None:
    before = digest(small)
    res = run_inproc("upgrade", str(small), str(small / "v3"))
    assert res.returncode == 2 and "inside OLD" in res.stderr
    assert digest(small) == before and not (small / "v3").exists()


def test_a_failure_midway_leaves_new_absent(small: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """lerobot's converter failing (here: its videos step) is one line; the staging folder is gone."""
    from lerobot.scripts import convert_dataset_v21_to_v30 as converter

    def broken(*_args: object, **_kw: object) -> None:
        raise ValueError("All cams dont have same number of episodes ([3, 2]).\nmore")

    monkeypatch.setattr(converter, "convert_videos", broken)
    _refused(small, tmp_path / "new", "lerobot's converter failed: All cams dont have same number")


def test_an_interrupt_leaves_new_absent(small: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from lerobot.scripts import convert_dataset_v21_to_v30 as converter

    def interrupted(*_args: object, **_kw: object) -> None:
        raise KeyboardInterrupt

    monkeypatch.setattr(converter, "convert_episodes_metadata", interrupted)
    with pytest.raises(KeyboardInterrupt):
        from openral_data.upgrade import upgrade

        upgrade(small, tmp_path / "new")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["old"]


def test_without_lerobot_one_line_naming_the_extra(
    small: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setitem(sys.modules, "lerobot.scripts.convert_dataset_v21_to_v30", None)
    _refused(small, tmp_path / "new", "pip install 'openral-data[lerobot]'", "uv sync --extra lerobot")


@pytest.mark.slow
def test_a_kill_leaves_new_absent_and_a_rerun_completes(small: Path, tmp_path: Path) -> None:
    """SIGKILL once lerobot's data step has written into the staging folder: NEW is absent, OLD as it was; the
    next run removes the dead run's staging folder and writes NEW."""
    from tests.support.interrupt import hidden_leftovers, kill_when_staged, snapshot

    before = snapshot(small)
    new = tmp_path / "new"
    kill_when_staged(["upgrade", str(small), str(new)], new, "data/*/*.parquet")
    assert not new.exists() and snapshot(small) == before
    _upgrade(small, new)
    assert hidden_leftovers(tmp_path) == [] and snapshot(small) == before
