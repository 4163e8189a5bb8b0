"""Episode editing: delete, split and merge re-index everything, and lerobot 0.6.1 loads the result frame-exactly.

The seeded mock scene makes every frame name its source episode (state[1] and green = the episode's seed), so
`verify_seeded_dataset` checks that output episode k holds exactly the frames of the episode its metadata says.
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path
from typing import Any

import av
import numpy as np
import pyarrow.parquet as pq
import pytest

from openral_data.doctor import check
from openral_data.edit import ops
from openral_data.errors import DatasetBusy, EpisodeSelectionError, OutputExists, UsageError
from openral_data.formats.lerobot_v3.lock import DatasetLock
from openral_data.record.options import RecordOptions
from openral_data.record.sim import record
from tests.support.cli import run_cli
from tests.support.curate import packets
from tests.support.scenes import mock_scene, write_yaml
from tests.support.seeded import episode_seeds, verify_seeded_dataset

LENGTHS = [5, 9, 3, 7]


def _record(project: Path, out: Path, seed: int, n: int, codec: str = "h264", **scene_over: Any) -> Path:
    scene = write_yaml(
        project / "scenes/sim/mock_edit.yaml",
        mock_scene(scene_id="mock_edit", success_after=LENGTHS, n_episodes=n, seeded=True, **scene_over),
    )
    record(RecordOptions(scene=str(scene), rskill="random-mock", out=out, codec=codec, seed=seed, n_episodes=n))  # type: ignore[arg-type]
    return out


def _digest(root: Path) -> dict[str, str]:
    return {
        str(p.relative_to(root)): hashlib.sha256(p.read_bytes()).hexdigest()
        for p in sorted(root.rglob("*"))
        if p.is_file()
    }


@pytest.fixture
def two(project: Path, tmp_path: Path) -> tuple[Path, Path]:
    return _record(project, tmp_path / "a", 0, 4), _record(project, tmp_path / "b", 4, 3)


def test_merge_delete_split_reindex_and_load_frame_exact(two: tuple[Path, Path], tmp_path: Path) -> None:
    a, b = two
    before = {p: _digest(p) for p in (a, b)}
    merged = tmp_path / "merged"
    res = run_cli("episodes", "merge", str(a), str(b), "--out", str(merged))
    assert res.returncode == 0, res.stderr
    seen = verify_seeded_dataset(merged)
    assert seen["seeds"] == [0, 1, 2, 3, 4, 5, 6]
    assert check(merged) == []  # doctor: healthy
    assert seen["lengths"] == [5, 9, 3, 7, 5, 9, 3]

    # inputs untouched, no staging folders left behind
    assert {p: _digest(p) for p in (a, b)} == before
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]
    # video packets are the sources' packets, remuxed, never re-encoded
    key = "observation.images.front"
    assert packets(merged, key) == packets(a, key) + packets(b, key)
    info = json.loads((merged / "meta/info.json").read_text())
    assert (info["total_episodes"], info["total_frames"], info["total_tasks"]) == (7, 41, 1)
    assert info["splits"] == {"train": "0:7"}
    edit = json.loads((merged / "meta/openral.json").read_text())["edit"]
    assert edit["op"] == "merge" and [s["episodes"] for s in edit["sources"]] == [[0, 1, 2, 3], [0, 1, 2]]


@pytest.mark.slow
def test_delete_and_split_load_frame_exact(two: tuple[Path, Path], tmp_path: Path) -> None:
    merged = ops.merge(list(two), tmp_path / "merged").out
    ops.delete(merged, "1,4", tmp_path / "deleted")
    seen = verify_seeded_dataset(tmp_path / "deleted")
    assert seen["seeds"] == [0, 2, 3, 5, 6] and seen["lengths"] == [5, 3, 7, 9, 3]
    ops.split(merged, "5,0", tmp_path / "picked", rest=tmp_path / "rest")
    assert verify_seeded_dataset(tmp_path / "picked")["seeds"] == [5, 0]  # in the order asked for
    assert verify_seeded_dataset(tmp_path / "rest")["seeds"] == [1, 2, 3, 4, 6]
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]


def test_delete_and_split_reindex_rows_metadata_and_videos(two: tuple[Path, Path], tmp_path: Path) -> None:
    """Without lerobot (fast): indices, offsets and video timestamps are consistent and name the right seeds."""
    merged = ops.merge(list(two), tmp_path / "merged").out
    ops.delete(merged, "1,4", tmp_path / "deleted")
    ops.split(merged, "5,0", tmp_path / "picked", rest=tmp_path / "rest")
    for name, seeds in (("deleted", [0, 2, 3, 5, 6]), ("picked", [5, 0]), ("rest", [1, 2, 3, 4, 6])):
        root = tmp_path / name
        assert episode_seeds(root) == seeds
        data = pq.read_table(sorted(root.glob("data/*/*.parquet"))[0])
        eps = pq.read_table(sorted(root.glob("meta/episodes/*/*.parquet"))[0]).to_pylist()
        assert data.column("index").to_pylist() == list(range(data.num_rows))
        state = np.stack(data.column("observation.state").to_numpy(zero_copy_only=False))
        start = 0
        for k, row in enumerate(eps):
            n = row["length"]
            assert row["episode_index"] == k and (row["dataset_from_index"], row["dataset_to_index"]) == (
                start,
                start + n,
            )
            assert data.column("episode_index").to_pylist()[start : start + n] == [k] * n
            assert (state[start : start + n, 1] == seeds[k]).all() and (
                state[start : start + n, 0] == np.arange(n)
            ).all()
            assert row["videos/observation.images.front/from_timestamp"] == pytest.approx(start / 20)
            start += n
        info = json.loads((root / "meta/info.json").read_text())
        assert (info["total_episodes"], info["total_frames"]) == (len(seeds), data.num_rows)
        assert check(root) == [], name  # doctor: healthy
        # camera stats of a subset are merged summaries: no histogram is left for a resume to continue wrongly
        assert not (root / ".openral" / "image_hist.json").exists()
        with av.open(str(sorted(root.glob("videos/observation.images.front/*/*.mp4"))[0])) as c:
            assert sum(1 for p in c.demux(c.streams.video[0]) if p.size) == data.num_rows


def test_merge_equals_a_fresh_recording_of_the_same_seeds(project: Path, tmp_path: Path) -> None:
    """Rows, episode metadata (per-episode stats, openral.* columns) and stats.json are bit-identical."""
    a, b = _record(project, tmp_path / "a", 0, 2), _record(project, tmp_path / "b", 2, 2)
    fresh = _record(project, tmp_path / "fresh", 0, 4)
    merged = ops.merge([b, a], tmp_path / "merged", order="seed").out
    assert episode_seeds(merged) == [0, 1, 2, 3]

    def table(root: Path, sub: str) -> list[dict[str, object]]:
        return pq.read_table(sorted(root.glob(f"{sub}/*/*.parquet"))[0]).to_pylist()

    assert table(merged, "data") == table(fresh, "data")
    assert table(merged, "meta/episodes") == table(fresh, "meta/episodes")
    # camera stats too: whole datasets are merged with their summed pixel histograms (exact)
    assert (merged / "meta/stats.json").read_text() == (fresh / "meta/stats.json").read_text()
    assert (merged / ".openral/image_hist.json").read_text() == (fresh / ".openral/image_hist.json").read_text()


def test_merge_refuses_other_features_naming_the_field(project: Path, tmp_path: Path) -> None:
    a = _record(project, tmp_path / "a", 0, 1)
    other = _record(project, tmp_path / "other", 0, 1, cameras=[("front", 64, 48)])  # (a resolution is re-encoded)
    out = tmp_path / "out"
    res = run_cli("episodes", "merge", str(a), str(other), "--out", str(out))
    assert res.returncode == 2
    assert res.stderr.count("\n") == 1 and res.stderr.startswith("error: "), res.stderr
    assert f"features.observation.images.wrist: in {a}, not in {other}" in res.stderr
    assert not out.exists()


def test_edit_errors_are_one_line_and_write_nothing(two: tuple[Path, Path], tmp_path: Path) -> None:
    a, _ = two
    with pytest.raises(EpisodeSelectionError) as excinfo:
        ops.delete(a, "9", tmp_path / "x")
    assert excinfo.value.code == "episodes.range" and str(excinfo.value).startswith("--episodes: '9'")
    with pytest.raises(EpisodeSelectionError) as excinfo:
        ops.delete(a, "0-3", tmp_path / "x")
    assert excinfo.value.code == "episodes.empty"
    (tmp_path / "taken").mkdir()
    (tmp_path / "taken" / "keep.txt").write_text("mine")
    with pytest.raises(OutputExists) as excinfo:
        ops.split(a, "0", tmp_path / "taken")
    assert excinfo.value.code == "output.exists"
    assert (tmp_path / "taken" / "keep.txt").read_text() == "mine"
    assert not (tmp_path / "x").exists()


def test_delete_in_place_replaces_the_input(two: tuple[Path, Path]) -> None:
    a, _ = two
    ops.delete(a, "0", None, in_place=True)
    assert episode_seeds(a) == [1, 2, 3]
    assert not [p for p in a.parent.iterdir() if p.name.startswith(".")]


def test_av1_episodes_are_cut_by_remux(project: Path, tmp_path: Path) -> None:
    """AV1 (the default codec) has no encoder in PyAV's build: cutting must be a pure packet remux."""
    src = _record(project, tmp_path / "av1", 0, 3, codec="av1")
    out = ops.delete(src, "1", tmp_path / "out").out
    key = "observation.images.front"
    src_packets = packets(src, key)
    assert packets(out, key) == src_packets[:5] + src_packets[5 + 9 :]
    assert verify_seeded_dataset(out)["seeds"] == [0, 2]


def test_delete_in_place_refuses_what_it_would_drop(two: tuple[Path, Path]) -> None:
    a, _ = two
    (a / "mcap").mkdir()
    # which usage mistake, and what would be dropped (mcap), is only in the wording
    with pytest.raises(UsageError, match="--in-place: mcap would not be carried over") as excinfo:
        ops.delete(a, "0", None, in_place=True)
    assert excinfo.value.code == "usage"
    assert episode_seeds(a) == [0, 1, 2, 3]


def test_a_dataset_being_recorded_is_not_edited(two: tuple[Path, Path], tmp_path: Path) -> None:
    a, _ = two
    with DatasetLock(a, "record"), pytest.raises(DatasetBusy) as excinfo:
        ops.split(a, "0", tmp_path / "x")
    assert excinfo.value.code == "dataset.busy" and "record" in excinfo.value.holder
    assert not (tmp_path / "x").exists()
