"""`.openral/digests.json` and its per-commit deltas: what a commit hashes, what a refresh keeps, what
`changed` reports, and what is refused."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from openral_data.errors import DatasetError
from openral_data.formats import atomic
from openral_data.formats.lerobot_v3 import digests, layout

DATA = "data/chunk-000/file-000.parquet"
DATA1 = "data/chunk-000/file-001.parquet"


def _dataset(root: Path) -> Path:
    (root / "data/chunk-000").mkdir(parents=True)
    (root / DATA).write_bytes(b"frames v1")
    (root / "meta").mkdir()
    (root / layout.STATS_PATH).write_bytes(b"{}")
    return root


def _commit(root: Path, episode: int, rels: list[str], info: bytes = b"{info}") -> None:
    """What a writer's commit stages: the delta of the files it wrote, hashed as staged, then renamed."""
    files = [(atomic.tmp_name(root / r) if atomic.tmp_name(root / r).is_file() else root / r, root / r) for r in rels]
    digests.delta_writer(root, files, {layout.INFO_PATH: info})(digests.delta_path(root, episode))
    for tmp, final in files:
        if tmp != final:
            tmp.replace(final)
    (root / layout.INFO_PATH).write_bytes(info)


def test_a_commit_hashes_its_staged_files_and_info_from_memory(tmp_path: Path) -> None:
    root = _dataset(tmp_path)
    assert digests.read(root) is None  # nothing recorded: not ours
    atomic.tmp_name(root / DATA).write_bytes(b"frames v2")  # staged in this commit: hashed as staged
    _commit(root, 0, [DATA, layout.STATS_PATH])
    m = digests.read(root)
    assert m is not None and set(m) == {DATA, layout.STATS_PATH, layout.INFO_PATH}
    assert m[DATA]["size"] == len(b"frames v2") and m[layout.INFO_PATH]["size"] == len(b"{info}")
    assert digests.changed(root, m) == []


def test_later_deltas_win_and_a_refresh_folds_them_into_the_base(tmp_path: Path) -> None:
    root = _dataset(tmp_path)
    _commit(root, 0, [DATA, layout.STATS_PATH], b"{info 0}")
    (root / DATA1).write_bytes(b"frames of episode 1")
    _commit(root, 1, [DATA1], b"{info 1}")
    before = digests.read(root)
    assert before is not None and set(before) == {DATA, DATA1, layout.STATS_PATH, layout.INFO_PATH}
    assert before[layout.INFO_PATH]["size"] == len(b"{info 1}")
    (root / DATA1).unlink()  # a join removed it
    digests.refresh(root, [root / DATA1])
    assert [k for k, _ in digests.deltas(root)] == []
    after = digests.read(root)
    assert after is not None and set(after) == {DATA, layout.STATS_PATH, layout.INFO_PATH}
    assert json.loads((root / digests.DIGESTS_PATH).read_text())["through"] == 1
    assert digests.changed(root, after) == []


def test_a_delta_left_by_a_crashed_refresh_does_not_undo_the_base(tmp_path: Path) -> None:
    """The base lands before the deltas go: a delta at or below `through` is old news and is skipped."""
    root = _dataset(tmp_path)
    _commit(root, 0, [DATA, layout.STATS_PATH])
    stale = digests.delta_path(root, 0).read_bytes()
    atomic.write_bytes(root / DATA, b"joined frames")
    digests.refresh(root, [root / DATA])
    digests.delta_path(root, 0).write_bytes(stale)  # as if the crash came before the delta was removed
    m = digests.read(root)
    assert m is not None and m[DATA]["size"] == len(b"joined frames")
    assert digests.changed(root, m) == []


def test_files_marked_before_a_join_are_rehashed_by_the_next_refresh(tmp_path: Path) -> None:
    root = _dataset(tmp_path)
    _commit(root, 0, [DATA, layout.STATS_PATH])
    digests.mark(root, [root / DATA])
    atomic.write_bytes(root / DATA, b"joined frames")  # the crash comes here: digests are stale
    stored = digests.read(root)
    assert stored is not None and digests.changed(root, stored) != []
    assert digests.pending(root) == [root / DATA]
    digests.refresh(root, [])  # what recovery runs
    stored = digests.read(root)
    assert stored is not None and digests.changed(root, stored) == []
    assert digests.pending(root) == [] and not (root / digests.REHASH_PATH).exists()


def test_a_byte_changed_in_place_is_not_taken_over_by_the_next_commit(tmp_path: Path) -> None:
    root = _dataset(tmp_path)
    _commit(root, 0, [DATA, layout.STATS_PATH])
    with open(root / DATA, "r+b") as fh:  # same inode, same size: not a write of ours
        fh.write(b"F")
    (root / DATA1).write_bytes(b"frames of episode 1")
    _commit(root, 1, [DATA1])  # the next commit hashes only what it wrote
    stored = digests.read(root)
    assert stored is not None
    assert digests.changed(root, stored) == [(DATA, "content differs from what was written (sha256)")]


def test_stored_keys_stay_inside_the_dataset(tmp_path: Path) -> None:
    root = _dataset(tmp_path)
    (root / ".openral").mkdir()
    (root / digests.DIGESTS_PATH).write_text(json.dumps({"../outside": {"sha256": "0" * 64, "size": 1}}))
    with pytest.raises(DatasetError) as excinfo:
        digests.read(root)
    assert excinfo.value.code == "dataset.unsafe"
    (root / digests.DIGESTS_PATH).write_text("[1, 2]")
    with pytest.raises(DatasetError) as excinfo:
        digests.read(root)
    assert excinfo.value.code == "dataset.invalid"


def test_deltas_and_the_rehash_list_are_untrusted_too(tmp_path: Path) -> None:
    root = _dataset(tmp_path)
    folder = atomic.state_dir(root, digests.DELTAS_DIR)
    (folder / "000000000.json").write_text(json.dumps({"files": {"../x": {"sha256": "0" * 64, "size": 1}}}))
    with pytest.raises(DatasetError) as excinfo:
        digests.read(root)
    assert excinfo.value.code == "dataset.unsafe"
    (folder / "000000000.json").unlink()
    (root / digests.REHASH_PATH).write_text(json.dumps(["../../etc/passwd", DATA]))
    assert digests.pending(root) == [root / DATA]  # only files the map covers are ever listed
    folder.rmdir()
    outside = tmp_path.parent / f"{tmp_path.name}-elsewhere"
    outside.mkdir()
    folder.symlink_to(outside)
    with pytest.raises(DatasetError) as excinfo:
        digests.read(root)
    assert excinfo.value.code == "dataset.unsafe"
    with pytest.raises(DatasetError):
        digests.delta_path(root, 0)  # a writer never writes through it either
