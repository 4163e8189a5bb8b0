"""`openral-data quality`, the quality views in `stats --sql` and `episodes filter --where`, the counts in
`stats` and `info`, and the cache: reused while the data is unchanged, recomputed once it changed."""

from __future__ import annotations

import json
import threading
from pathlib import Path

import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from openral_data.formats.lerobot_v3.video import concat_mp4
from openral_data.metrics.quality import FLAGS, Quality, cache, quality_of
from openral_data.metrics.sources import open_dataset
from tests.support import quality as q
from tests.support.inproc import run_inproc
from tests.support.lerobot_written import digest, loaded_episodes, same_frames, write_lerobot_dataset
from tests.support.metrics import data_file, rewrite_parquet

N = 40


@pytest.fixture(autouse=True)
def _user_cache(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))


def _dataset(root: Path) -> Path:
    """Three moving episodes, the middle one idle for its first 30 of 40 frames (then off at full speed)."""
    return q.idle_middle(root, N)


def _ok(*args: str) -> str:
    run = run_inproc(*args)
    assert run.returncode == 0, run.stderr
    return run.stdout


def _identity(path: Path) -> tuple[int, int]:
    st = path.stat()
    return st.st_ino, st.st_mtime_ns


def test_quality_command_lists_flagged_episodes(tmp_path: Path) -> None:
    root = _dataset(tmp_path / "ds")
    out = json.loads(_ok("quality", str(root), "--format", "json"))
    assert out["quality"] == [
        {"dataset": "ds", "computed": True, "episodes": 3, "flagged": 1} | {k: int(k == "idle") for k in FLAGS}
    ]
    [row] = out["episodes"]
    assert (row["episode_index"], row["flags"], row["idle_head"]) == (
        1,
        ["idle"],
        30,
    )  # it sets off at full speed
    assert len(json.loads(_ok("quality", str(root), "--all", "--format", "json"))["episodes"]) == 3
    assert (root / ".openral" / "quality.parquet").is_file()  # ours: cached in the dataset's .openral/


def test_cache_reused_until_the_data_changes(tmp_path: Path) -> None:
    root = _dataset(tmp_path / "ds")
    first = run_inproc("quality", str(root))
    assert first.returncode == 0 and "quality: computed:" in first.stderr
    cached = root / ".openral" / "quality.parquet"
    before = _identity(cached)
    again = run_inproc("quality", str(root))
    assert again.returncode == 0 and "quality: cached:" in again.stderr
    assert _identity(cached) == before  # not rewritten: the same inode and mtime
    # make episode 0 hold still for its whole length: the data changed, so the table is computed again
    path = data_file(root)
    table = pq.read_table(path)
    episode = table["episode_index"].to_pylist()
    for key in ("observation.state", "action"):
        values = table[key].to_pylist()
        still = pa.array([values[0] if e == 0 else v for v, e in zip(values, episode, strict=True)], table[key].type)
        table = table.set_column(table.schema.get_field_index(key), key, still)
    rewrite_parquet(path, table)
    third = run_inproc("quality", str(root), "--all", "--format", "json")
    assert third.returncode == 0 and "quality: computed:" in third.stderr
    assert _identity(cached) != before
    assert json.loads(third.stdout)["episodes"][0]["idle_fraction"] == 1.0


def test_filter_where_quality_and_lerobot_loads_the_output(tmp_path: Path) -> None:
    root = _dataset(tmp_path / "ds")
    out = tmp_path / "kept"
    assert "episodes 2" in _ok(
        "episodes", "filter", str(root), "--where", "quality.idle_fraction < 0.5", "--out", str(out)
    )
    src = loaded_episodes(root)
    got = loaded_episodes(out)
    assert len(got) == 2
    for g, w in zip(got, [src[0], src[2]], strict=True):
        same_frames(g, w)


def test_filter_where_quality_on_a_lerobot_written_dataset(tmp_path: Path) -> None:
    root = tmp_path / "lerobot"
    write_lerobot_dataset(root, with_success=True)
    before = digest(root)
    out = tmp_path / "kept"
    assert "episodes 3" in _ok("episodes", "filter", str(root), "--where", "NOT quality.idle", "--out", str(out))
    assert digest(root) == before  # the table went to the user cache
    src, got = loaded_episodes(root), loaded_episodes(out)
    for g, w in zip(got, src, strict=True):
        same_frames(g, w)


def test_filter_without_quality_computes_nothing(tmp_path: Path) -> None:
    root = _dataset(tmp_path / "ds")
    _ok("episodes", "filter", str(root), "--where", "length > 0", "--out", str(tmp_path / "all"))
    assert not (root / ".openral" / "quality.parquet").exists()


def test_stats_sql_joins_quality_with_episodes_and_frames(tmp_path: Path) -> None:
    root = _dataset(tmp_path / "ds")
    sql = (
        "SELECT e.episode_index, q.idle_head, (SELECT count(*) FROM quality_frames f WHERE f.idle "
        "AND f.episode_index = e.episode_index) AS idle_frames FROM episodes e JOIN quality q "
        "USING (dataset, episode_index) ORDER BY 1"
    )
    rows = json.loads(_ok("stats", str(root), "--sql", sql, "--format", "json"))["sql"]
    assert [(r["episode_index"], r["idle_head"], r["idle_frames"]) for r in rows] == [(0, 0, 0), (1, 30, 30), (2, 0, 0)]
    samples = json.loads(
        _ok("stats", str(root), "--sql", "SELECT count(*) AS n FROM quality_camera_frames", "--format", "json")
    )
    assert samples["sql"] == [{"n": 3 * N // 5}]  # every 5th frame of the one camera


def test_stats_report_and_info_show_flagged_counts(tmp_path: Path) -> None:
    root = _dataset(tmp_path / "ds")
    report = json.loads(_ok("stats", str(root), "--format", "json"))
    assert report["quality"][0]["computed"] is False and report["quality"][0]["flagged"] is None
    assert "not computed" in _ok("info", str(root))
    _ok("quality", str(root))
    report = json.loads(_ok("stats", str(root), "--format", "json"))
    assert (report["quality"][0]["flagged"], report["quality"][0]["idle"]) == (1, 1)
    assert "1 of 3 episodes flagged (idle 1)" in _ok("info", str(root))


def test_bad_stride_is_a_usage_error(tmp_path: Path) -> None:
    root = _dataset(tmp_path / "ds")
    run = run_inproc("quality", str(root), "--stride", "0")
    assert run.returncode == 2 and run.stderr.startswith("error: --stride")
    assert not (root / ".openral" / "quality.parquet").exists()


def test_read_only_dataset_cached_in_the_user_cache(tmp_path: Path) -> None:
    from tests.support.readonly import read_only_view

    root = _dataset(tmp_path / "ds")
    with read_only_view(root, tmp_path / "ro") as ro:
        assert "quality: computed:" in run_inproc("quality", str(ro)).stderr
        assert "quality: cached:" in run_inproc("quality", str(ro)).stderr
    assert not (root / ".openral" / "quality.parquet").exists()
    assert any((tmp_path / "xdg" / "openral-data" / "quality").glob("*/quality.parquet"))


def test_a_damaged_dataset_is_one_error_line_and_nothing_cached(tmp_path: Path) -> None:
    root = _dataset(tmp_path / "ds")
    video = sorted(root.glob("videos/*/*/*.mp4"))[0]
    video.write_bytes(video.read_bytes()[:3000])
    run = run_inproc("quality", str(root))
    lines = [ln for ln in run.stderr.splitlines() if ln.strip()]
    assert run.returncode == 2 and len(lines) == 1 and lines[0].startswith(f"error: {video}: cannot decode video")
    left = sorted(p.name for p in (root / ".openral").iterdir() if "quality" in p.name)
    assert left == [cache.LOCK]  # no table, nothing staged: only the lock a computation takes (`cache.computing`)


def test_a_video_shorter_than_its_episode_is_a_finding(tmp_path: Path) -> None:
    """The camera's mp4 loses its last 6 frames (packets), all in the last episode: that episode gets a
    `video_frames` finding on the frames the video lacks (34 held of 40) and its flag; every episode's other
    checks are still computed (the middle one's idle), the others raise no `video_frames` (was: one error line)."""
    root = _dataset(tmp_path / "ds")
    video = sorted(root.glob("videos/*/*/*.mp4"))[0]
    short = video.with_name("short.mp4")
    concat_mp4([(video, 3 * N - 6)], short, q.FPS)  # its first 3 * N - 6 packets
    short.replace(video)
    run = run_inproc("quality", str(root), "--format", "json")
    assert run.returncode == 0, run.stderr
    got = quality_of(open_dataset(root))
    rows = got.table.to_pylist()
    assert [(r["idle"], r["video_frames"]) for r in rows] == [(False, False), (True, False), (False, True)]
    found = [f for f in pq.read_table(got.paths.findings).to_pylist() if f["check"] == "video_frames"]
    assert [(f["episode_index"], f["subject"], f["start_frame"], f["end_frame"]) for f in found] == [
        (2, "observation.images.cam", N - 6, N - 1)
    ]
    assert (found[0]["value"], found[0]["threshold"]) == (N - 6, N)
    samples = pq.read_table(got.paths.camera_frames).to_pylist()  # the frames it holds were measured
    assert max(s["frame_index"] for s in samples if s["episode_index"] == 2) == N - 6 - 4


def test_stats_sql_without_quality_computes_nothing(tmp_path: Path) -> None:
    root = _dataset(tmp_path / "ds")
    _ok("stats", str(root), "--sql", "SELECT count(*) FROM episodes")
    assert not (root / ".openral" / "quality.parquet").exists()
    rows = json.loads(_ok("stats", str(root), "--sql", "SELECT count(*) AS n FROM quality", "--format", "json"))
    assert rows["sql"] == [{"n": 3}]  # naming it computes it


def test_a_second_quality_of_the_same_dataset_waits_for_the_first(tmp_path: Path) -> None:
    """Two `quality` computations of one dataset at once: the second, started while the first is measuring its
    cameras, waits for it (the staged tables have fixed names: without the wait it cleared the first one's
    staged files, whose commit then failed) and both come back with the same table, cached whole."""
    root = _dataset(tmp_path / "ds")
    got: dict[str, Quality] = {}
    threads: list[threading.Thread] = []

    def start_second(_: int) -> None:
        if threads:
            return
        threads.append(
            threading.Thread(target=lambda: got.update(second=quality_of(open_dataset(root), recompute=True)))
        )
        threads[0].start()
        threads[0].join(timeout=1.5)  # it had ended by now, had it not waited
        got["early"] = got.get("second", first_done)

    first_done = Quality(pa.table({}), cache.cache_paths(root), computed=False)  # a marker: not yet
    first = quality_of(open_dataset(root), recompute=True, progress=start_second)
    assert got["early"] is first_done  # the second was still waiting when the first went on
    threads[0].join()
    assert got["second"].computed and first.computed
    assert got["second"].table.equals(first.table)
    again = quality_of(open_dataset(root))
    assert not again.computed and again.table.equals(first.table)
    assert not [p.name for p in (root / ".openral").iterdir() if p.name.endswith(".tmp")]  # nothing staged left
