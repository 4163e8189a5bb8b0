"""Commits that stay flat: an episode's commit writes its own data, meta/episodes and digest files and leaves
every earlier one untouched; the runs are joined every `staged_episodes`, at a data rotation and at close, and
lerobot 0.6.1 loads the dataset frame-exact after every commit and every join."""

from __future__ import annotations

import os
from pathlib import Path

import pyarrow.parquet as pq

from openral_data.doctor import check
from openral_data.formats.lerobot_v3 import LeRobotV3Writer, VideoSettings, WriterConfig, digests
from openral_data.formats.lerobot_v3.reader import read_episodes
from openral_data.formats.lerobot_v3.recovery import recover
from openral_data.runtime.bridge import DatasetBridge
from tests.support.patterned import check_loads, dataset_states, write_dataset, write_episodes

H264 = VideoSettings(codec="h264")


def _inodes(root: Path, pattern: str) -> dict[str, int]:
    return {str(p.relative_to(root)): os.stat(p).st_ino for p in root.glob(pattern)}


def test_a_commit_writes_only_its_own_files_and_loads_after_every_commit(tmp_path: Path) -> None:
    """With room for every episode, each commit adds one data file and one episodes file and replaces none of
    the earlier ones (their inodes stay), the digests of earlier commits stay in their deltas, and lerobot loads
    the dataset after each commit. close() joins them into one data and one episodes file."""
    root = tmp_path / "ds"
    lengths = [3, 5, 4, 6, 2]
    seen_data: dict[str, int] = {}
    seen_eps: dict[str, int] = {}

    def after_commit(e: int) -> None:
        data, eps = _inodes(root, "data/*/*.parquet"), _inodes(root, "meta/episodes/*/*.parquet")
        assert len(data) == len(eps) == e + 1
        assert {k: data[k] for k in seen_data} == seen_data and {k: eps[k] for k in seen_eps} == seen_eps
        seen_data.update(data)
        seen_eps.update(eps)
        assert [k for k, _ in digests.deltas(root)] == list(range(e + 1))
        stored = digests.read(root)
        assert stored is not None and digests.changed(root, stored) == []

    _, states = write_dataset(
        root, lengths, config=WriterConfig(video=H264), check_after_each=True, after_each=after_commit
    )
    assert len(list(root.glob("data/*/*.parquet"))) == 1 and len(list(root.glob("meta/episodes/*/*.parquet"))) == 1
    assert pq.ParquetFile(next(root.glob("data/*/*.parquet"))).num_row_groups == len(lengths)  # one per episode
    assert digests.deltas(root) == [] and not (root / digests.REHASH_PATH).exists()
    check_loads(root, lengths, states)
    assert check(root) == []


def _rows_name_their_files(root: Path) -> None:
    """Each data file holds exactly the episodes whose rows (as on disk) name it, each episodes row sits in the
    file it names, and no episode is listed twice."""
    eps = read_episodes(root).to_pydict()
    assert eps["episode_index"] == list(range(len(eps["episode_index"])))
    for path in sorted(root.glob("data/*/*.parquet")):
        chunk, file = int(path.parent.name[6:]), int(path.stem[5:])
        named = [e for e, c, f in zip(eps["episode_index"], eps["data/chunk_index"], eps["data/file_index"],
                                      strict=True) if (c, f) == (chunk, file)]  # fmt: skip
        assert sorted(set(pq.read_table(path, columns=["episode_index"])["episode_index"].to_pylist())) == named
    for path in sorted(root.glob("meta/episodes/*/*.parquet")):
        t = pq.read_table(path, columns=["meta/episodes/chunk_index", "meta/episodes/file_index"]).to_pydict()
        assert set(zip(*t.values(), strict=True)) == {(int(path.parent.name[6:]), int(path.stem[5:]))}


def test_runs_join_every_staged_episodes_and_at_rotation_loading_after_each(tmp_path: Path) -> None:
    """staged_episodes=3 joins the runs before every fourth staged episode; 1 MiB data files (6,000 floats a
    frame) rotate, and so do the episodes files (a row holds 6,000-wide statistics: about 480 KB), so a data
    rotation also lands right after an episodes rotation. After every commit lerobot loads the dataset and every
    row names the files that hold it."""
    root = tmp_path / "ds"
    lengths = [3, 5, 8, 4, 6, 7, 3, 8, 5]
    config = WriterConfig(video=H264, staged_episodes=3, data_files_size_in_mb=1)
    _, states = write_dataset(
        root,
        lengths,
        state_dim=6000,
        config=config,
        check_after_each=True,
        after_each=lambda e: _rows_name_their_files(root),
    )
    assert len(sorted(root.glob("data/*/*.parquet"))) >= 2
    assert len(sorted(root.glob("meta/episodes/*/*.parquet"))) >= 2
    _rows_name_their_files(root)
    check_loads(root, lengths, states)
    assert check(root) == []


def test_resume_continues_the_staged_runs(tmp_path: Path) -> None:
    """A writer that stops between commits (never closed, as after a SIGKILL there) leaves per-episode files;
    recovery keeps them all, and a resumed writer joins them with its own episodes at close, loading exactly."""
    root = tmp_path / "ds"
    config = WriterConfig(video=H264, staged_episodes=100)
    writer, _ = write_dataset(root, [3, 4, 2], config=config, close=False)
    assert len(list(root.glob("data/*/*.parquet"))) == 3
    assert recover(root) == []
    resumed = LeRobotV3Writer(root, writer.schema, config, resume=True)
    assert resumed.total_episodes == 3
    bridge = DatasetBridge(writer.schema, [resumed])
    write_episodes(bridge, [3, 4, 2, 5], first=3)
    bridge.close()
    assert len(list(root.glob("data/*/*.parquet"))) == 1 and len(list(root.glob("meta/episodes/*/*.parquet"))) == 1
    assert read_episodes(root).to_pydict()["episode_index"] == [0, 1, 2, 3]
    check_loads(root, [3, 4, 2, 5], dataset_states([3, 4, 2, 5]))
    assert check(root) == []


def test_staged_files_roll_over_chunks_in_the_order_lerobot_reads_them(tmp_path: Path) -> None:
    """chunks_size=3: the per-episode files of 7 episodes fill chunk-000 and chunk-001 and start chunk-002;
    lerobot's sorted glob still reads them in episode order after every commit."""
    root = tmp_path / "ds"
    lengths = [2, 3, 2, 4, 2, 3, 2]
    config = WriterConfig(video=H264, chunks_size=3, staged_episodes=10)

    def after_commit(e: int) -> None:
        if e == len(lengths) - 1:
            chunks = sorted(p.parent.name for p in root.glob("data/*/*.parquet"))
            assert chunks == ["chunk-000"] * 3 + ["chunk-001"] * 3 + ["chunk-002"]

    _, states = write_dataset(root, lengths, config=config, check_after_each=True, after_each=after_commit)
    check_loads(root, lengths, states)
    assert check(root) == []
