"""`episodes filter --where SQL` and `episodes split --fractions`: the right episodes, re-indexed, frame-exact.

The seeded mock scene makes every frame name its source episode (state[1] and green = the episode's seed, which
is its index in the source), so an output episode can be compared row by row with the source episode it names.
Outcomes are known: an episode succeeds after `SUCCESS_AFTER[k]` steps, or fails at `MAX_STEPS`.
"""

from __future__ import annotations

import hashlib
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from openral_data.doctor import check
from openral_data.edit import select
from openral_data.errors import DatasetBusy, EpisodeSelectionError, QueryError, UsageError
from openral_data.formats.lerobot_v3.lock import DatasetLock
from openral_data.record.options import RecordOptions
from openral_data.record.sim import record
from tests.support.cli import run_cli
from tests.support.scenes import mock_scene, write_yaml
from tests.support.seeded import episode_seeds, verify_seeded_dataset

MAX_STEPS = 20
SUCCESS_AFTER = [5, 30, 9, 3, 30, 12]  # lengths 5, 20, 9, 3, 20, 12; success T F T T F T
LENGTHS = [min(s, MAX_STEPS) for s in SUCCESS_AFTER]
SUCCESS = [s <= MAX_STEPS for s in SUCCESS_AFTER]
ROW_COLUMNS = ["observation.state", "action", "timestamp", "frame_index", "next.reward", "next.done"]


@pytest.fixture
def ds(project: Path, tmp_path: Path) -> Path:
    scene = write_yaml(
        project / "scenes/sim/mock_select.yaml",
        mock_scene(
            scene_id="mock_select",
            success_after=SUCCESS_AFTER,
            max_steps=MAX_STEPS,
            n_episodes=len(SUCCESS_AFTER),
            seeded=True,
        ),
    )
    out = tmp_path / "src"
    opts = RecordOptions(scene=str(scene), rskill="random-mock", out=out, codec="h264", seed=0, n_episodes=6)  # type: ignore[arg-type]
    record(opts)
    return out


def _digest(root: Path) -> dict[str, str]:
    return {
        str(p.relative_to(root)): hashlib.sha256(p.read_bytes()).hexdigest() for p in root.rglob("*") if p.is_file()
    }


def _rows(root: Path) -> pa.Table:
    return pa.concat_tables(pq.read_table(f) for f in sorted(root.glob("data/*/*.parquet")))


def _episode_rows(table: pa.Table, e: int) -> dict[str, list[object]]:
    mask = np.asarray(table.column("episode_index").to_numpy()) == e
    sub = table.filter(pa.array(mask))
    return {c: sub.column(c).to_pylist() for c in ROW_COLUMNS if c in sub.column_names}


def assert_episodes_of(out: Path, src: Path, seeds: list[int]) -> None:
    """`out` holds exactly the source episodes `seeds` (seed = source index), in order, row for row; healthy."""
    assert episode_seeds(out) == seeds
    source, rows = _rows(src), _rows(out)
    assert rows.column("index").to_pylist() == list(range(rows.num_rows))
    for k, e in enumerate(seeds):
        got, want = _episode_rows(rows, k), _episode_rows(source, e)
        assert got == want and len(got["timestamp"]) == LENGTHS[e], (k, e)
    assert check(out) == []  # doctor: healthy


# -- filter --------------------------------------------------------------------------------------------------
def test_filter_keeps_exactly_the_matching_episodes_and_loads_frame_exact(ds: Path, tmp_path: Path) -> None:
    before = _digest(ds)
    out = tmp_path / "good"
    res = run_cli("episodes", "filter", str(ds), "--where", "success AND length > 4", "--out", str(out))
    assert res.returncode == 0, res.stderr
    expected = [e for e in range(6) if SUCCESS[e] and LENGTHS[e] > 4]
    assert expected == [0, 2, 5]
    assert_episodes_of(out, ds, expected)
    seen = verify_seeded_dataset(out)  # lerobot 0.6.1 loads it, frame by frame
    assert seen["lengths"] == [LENGTHS[e] for e in expected]
    success = pq.read_table(sorted(out.glob("meta/episodes/*/*.parquet"))[0]).column("openral.success").to_pylist()
    assert success == [True, True, True]
    assert _digest(ds) == before  # the source is only read
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]  # no staging folder left


def test_filter_sees_openral_columns_and_subqueries_and_replaces_in_place(ds: Path, tmp_path: Path) -> None:
    select.filter_episodes(ds, '"openral.success" IS FALSE', tmp_path / "failed")
    assert_episodes_of(tmp_path / "failed", ds, [1, 4])
    select.filter_episodes(ds, "length < (SELECT avg(length) FROM episodes) OR seed = 4", tmp_path / "short")
    assert_episodes_of(tmp_path / "short", ds, [0, 2, 3, 4])  # avg 11.5
    kept = tmp_path / "kept"
    select.filter_episodes(ds, "seed IN (3, 1)", kept)  # a reference copy of what in-place must produce
    result = select.filter_episodes(ds, "seed IN (3, 1)", None, in_place=True)
    assert (result.out, result.episodes, result.frames) == (ds, 2, LENGTHS[1] + LENGTHS[3])
    assert episode_seeds(ds) == [1, 3] and check(ds) == []
    assert _rows(ds).equals(_rows(kept))
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]


@pytest.mark.parametrize(
    ("where", "code", "says"),
    [
        ("success AND", "query", "--where: Parser Error"),
        ("no_such_column > 1", "query", "no_such_column"),
        ("length > 1000", "episodes.empty", "matches no episode"),
        ("true); COPY (SELECT 1) TO 'x.csv'; SELECT (1", "query", "is not one predicate"),
    ],
)
def test_filter_refusals_are_one_line_and_write_nothing(
    ds: Path, tmp_path: Path, where: str, code: str, says: str
) -> None:
    before = _digest(ds)
    out = tmp_path / "out"
    with pytest.raises((QueryError, EpisodeSelectionError)) as excinfo:
        select.filter_episodes(ds, where, out)
    assert excinfo.value.code == code and says in str(excinfo.value)
    res = run_cli("episodes", "filter", str(ds), "--where", where, "--out", str(out))
    assert res.returncode == 2
    assert res.stderr.count("\n") == 1 and res.stderr.startswith("error: --where: "), res.stderr
    assert not out.exists() and _digest(ds) == before
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]


def test_filter_needs_out_or_in_place(ds: Path, tmp_path: Path) -> None:
    with pytest.raises(UsageError, match="--out"):
        select.filter_episodes(ds, "success", None)
    with pytest.raises(UsageError, match="--out"):
        select.filter_episodes(ds, "success", tmp_path / "x", in_place=True)


def test_a_dataset_being_recorded_is_neither_filtered_nor_split(ds: Path, tmp_path: Path) -> None:
    before = _digest(ds)
    with DatasetLock(ds, "record"):
        for edit in (
            lambda: select.filter_episodes(ds, "success", None, in_place=True),
            lambda: select.filter_episodes(ds, "success", tmp_path / "x"),
            lambda: select.split_fractions(ds, "0.5,0.5", tmp_path / "x"),
        ):
            with pytest.raises(DatasetBusy) as excinfo:
                edit()
            assert excinfo.value.code == "dataset.busy" and "record" in excinfo.value.holder
    assert not (tmp_path / "x").exists() and _digest(ds) == before


# -- split --fractions ---------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("total", "fractions", "sizes"),
    [
        (10, [0.8, 0.1, 0.1], [8, 1, 1]),
        (7, [0.5, 0.25, 0.25], [3, 2, 2]),  # quotas 3.5, 1.75, 1.75: the two largest remainders get the 2 left
        (6, [0.5, 0.3, 0.2], [3, 2, 1]),
        (3, [1 / 3, 1 / 3, 1 / 3], [1, 1, 1]),
        (5, [0.9, 0.05, 0.05], [5, 0, 0]),
    ],
)
def test_part_sizes_by_largest_remainder(total: int, fractions: list[float], sizes: list[int]) -> None:
    assert select.part_sizes(total, fractions) == sizes


def test_partition_is_complete_disjoint_and_seeded() -> None:
    parts = select.partition(50, [0.8, 0.1, 0.1], seed=7)
    assert [len(p) for p in parts] == [40, 5, 5]
    assert sorted(e for p in parts for e in p) == list(range(50))  # disjoint and complete
    assert all(p == sorted(p) for p in parts)
    assert select.partition(50, [0.8, 0.1, 0.1], seed=7) == parts  # reproducible
    assert select.partition(50, [0.8, 0.1, 0.1], seed=8) != parts  # another seed, another partition


@pytest.mark.parametrize(
    ("fractions", "names", "error", "says"),
    [
        ("0.5,0.4", None, UsageError, "sums to 0.9, not 1"),
        ("1", None, UsageError, "at least two parts"),
        ("0.5,x", None, UsageError, "not a comma-separated list"),
        ("1.5,-0.5", None, UsageError, "must be > 0"),
        ("0.5,0.5", "a,b,c", UsageError, "3 names for 2 fractions"),
        ("0.5,0.5", "a,a", UsageError, "repeats a name"),
        ("0.25,0.25,0.25,0.25", None, UsageError, "4 fractions need 4 names"),
        ("0.9,0.05,0.05", None, EpisodeSelectionError, "leaves val empty"),
    ],
)
def test_split_fractions_refusals_write_nothing(
    ds: Path, tmp_path: Path, fractions: str, names: str | None, error: type[Exception], says: str
) -> None:
    with pytest.raises(error, match=says):
        select.split_fractions(ds, fractions, tmp_path / "parts", names)
    assert not (tmp_path / "parts").exists()


def test_split_fractions_refuses_an_unsafe_name_and_an_existing_part(ds: Path, tmp_path: Path) -> None:
    res = run_cli("episodes", "split", str(ds), "--fractions", "0.5,0.5", "--names", "a,..", "--out-dir", "p")
    assert res.returncode == 2 and res.stderr.startswith("error: --names: '..'"), res.stderr
    (tmp_path / "parts" / "val").mkdir(parents=True)
    (tmp_path / "parts" / "val" / "keep.txt").write_text("mine")
    res = run_cli("episodes", "split", str(ds), "--fractions", "0.5,0.5", "--out-dir", str(tmp_path / "parts"))
    assert res.returncode == 2 and res.stderr.count("\n") == 1, res.stderr
    assert sorted(p.name for p in (tmp_path / "parts").iterdir()) == ["val"]  # train was not written either
    assert (tmp_path / "parts" / "val" / "keep.txt").read_text() == "mine"
    res = run_cli("episodes", "split", str(ds), "--fractions", "0.5,0.5", "--out", str(tmp_path / "x"))
    assert res.returncode == 2 and res.stderr.startswith("error: --fractions: give --out-dir"), res.stderr


def test_split_fractions_writes_seeded_healthy_parts(ds: Path, tmp_path: Path) -> None:
    before = _digest(ds)
    parts = tmp_path / "parts"
    res = run_cli("episodes", "split", str(ds), "--fractions", "0.5,0.3,0.2", "--seed", "3", "--out-dir", str(parts))
    assert res.returncode == 0, res.stderr
    seeds = {name: episode_seeds(parts / name) for name in ("train", "val", "test")}
    assert [len(s) for s in seeds.values()] == [3, 2, 1]
    assert sorted(e for s in seeds.values() for e in s) == list(range(6))  # disjoint, complete
    assert list(seeds.values()) == select.partition(6, [0.5, 0.3, 0.2], 3)
    for name, part in seeds.items():
        assert_episodes_of(parts / name, ds, part)
        assert verify_seeded_dataset(parts / name)["seeds"] == part  # lerobot loads each part frame-exact
    again = select.split_fractions(ds, "0.5,0.3,0.2", tmp_path / "again", "a,b,c", seed=3)
    assert [r.out.name for r in again] == ["a", "b", "c"]
    assert [episode_seeds(r.out) for r in again] == list(seeds.values())  # the same seed, the same parts
    other = select.split_fractions(ds, "0.5,0.5", tmp_path / "other", seed=11)
    assert [r.out.name for r in other] == ["train", "val"] and [r.episodes for r in other] == [3, 3]
    assert [episode_seeds(r.out) for r in other] == select.partition(6, [0.5, 0.5], 11)
    assert _digest(ds) == before
