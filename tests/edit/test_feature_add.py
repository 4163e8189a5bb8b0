"""`features add --name KEY --sql EXPR`: a column DuckDB computes from each frame's columns (list arithmetic,
CASE, a window over the episode), its shape and dtype inferred or declared, its statistics computed per episode
and for the dataset; every other column and video packet copied unchanged; lerobot 0.6.1 loads it; doctor
--deep finds the result healthy; bad SQL, NULL, ragged or non-numeric results are one line, exit 2, nothing
written."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest

from openral_data.doctor import check
from tests.support.curate import lerobot_items, packets, refused
from tests.support.inproc import run_inproc
from tests.support.lerobot_written import LENGTHS, VIDEO_CAMERA, digest, write_lerobot_dataset


@pytest.fixture(scope="module")
def source(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("add") / "lerobot"
    write_lerobot_dataset(root, with_success=True, image_camera=True)
    return root


def _added(src: Path, out: Path, name: str, sql: str, *more: str) -> None:
    res = run_inproc("features", "add", str(src), "--name", name, "--sql", sql, *more, "--out", str(out))
    assert res.returncode == 0, res.stderr
    assert res.stdout.startswith(f"added: {out}  episodes 3  frames {sum(LENGTHS)}")


def _rows(root: Path, key: str) -> np.ndarray:
    col = pq.read_table(root / "data").sort_by("index").column(key).to_pylist()
    return np.asarray(col, dtype=np.float64).reshape(len(col), -1)


def test_derived_columns_are_computed_with_their_statistics(source: Path, tmp_path: Path) -> None:
    before = digest(source)
    rel, grip, dvx = tmp_path / "rel", tmp_path / "grip", tmp_path / "dvx"
    _added(source, rel, "action.relative", 'vsub(action, "observation.state"[1:2])')
    _added(rel, grip, "gripper", "CASE WHEN action[1] > 0.25 THEN 1.0 ELSE 0.0 END", "--names", "closed")
    _added(grip, dvx, "action.delta", "action[1] - lag(action[1], 1, action[1]) OVER ep")
    assert check(dvx, deep=True) == []
    action, state = _rows(source, "action"), _rows(source, "observation.state")
    episode = _rows(source, "episode_index")[:, 0]
    delta = np.concatenate([np.diff(action[episode == e, 0], prepend=action[episode == e, 0][:1]) for e in range(3)])
    want = {
        "action.relative": action - state[:, :2],
        "gripper": (action[:, :1] > 0.25).astype(np.float64),
        "action.delta": delta[:, None],
    }
    info = json.loads((dvx / "meta/info.json").read_text())["features"]
    assert info["action.relative"] == {"dtype": "float32", "shape": [2], "names": None}
    assert info["gripper"] == {"dtype": "float32", "shape": [1], "names": ["closed"]}
    stats = json.loads((dvx / "meta/stats.json").read_text())
    eps = pq.read_table(dvx / "meta/episodes").to_pylist()
    for key, values in want.items():
        assert np.allclose(_rows(dvx, key), values, atol=1e-6), key
        assert np.allclose(stats[key]["mean"], values.mean(axis=0), atol=1e-6) and stats[key]["count"] == [19]
        for e, row in enumerate(eps):
            assert np.allclose(row[f"stats/{key}/max"], values[episode == e].max(axis=0), atol=1e-6)
    src_data = pq.read_table(source / "data").sort_by("index")
    data = pq.read_table(dvx / "data").sort_by("index")
    assert data.select(src_data.column_names).equals(src_data)  # every existing column unchanged
    assert packets(dvx, VIDEO_CAMERA) == packets(source, VIDEO_CAMERA)
    items = lerobot_items(dvx, ["action.relative", "gripper", "action.delta"])
    assert np.allclose([it["action.relative"] for it in items], want["action.relative"], atol=1e-6)
    assert digest(source) == before


def test_declared_dtype_and_shape(source: Path, tmp_path: Path) -> None:
    out = tmp_path / "out"
    _added(source, out, "moving", "action[1] > 0.25", "--dtype", "bool", "--shape", "1")
    assert json.loads((out / "meta/info.json").read_text())["features"]["moving"]["dtype"] == "bool"
    assert pq.read_table(out / "data").column("moving").to_pylist().count(True) == int(
        (_rows(source, "action")[:, 0] > 0.25).sum()
    )
    assert check(out, deep=True) == []
    other = tmp_path / "other"
    line = refused(
        "features", "add", str(source), "--name", "x", "--sql", "action", "--shape", "3", "--out", str(other)
    )
    assert line == "error: --shape: 3 but --sql gives 2 value(s) a frame"
    line = refused(
        "features", "add", str(source), "--name", "x", "--sql", "action[2]", "--dtype", "int64", "--out", str(other)
    )
    assert line.startswith(f"error: --sql: {source}: episode 0: the values are not int64: ")
    assert not other.exists()


@pytest.mark.parametrize(
    ("name", "sql", "says"),
    [
        ("x", "nope(", "--sql: Parser Error"),
        ("x", "NULL::FLOAT", "the expression is NULL in some frame"),
        ("x", "'text'", "the expression gives string values, not numbers"),
        ("x", "CASE WHEN frame_index > 2 THEN [1.0] ELSE [1.0, 2.0] END", "(ragged)"),
        ("x", "1) FROM t; SELECT (1", "is not one expression"),
        ("x", "(SELECT count(*) FROM read_csv('/etc/hostname'))", "--sql: Permission Error"),
        ("observation.images.wrist", "1.0", "already has a feature 'observation.images.wrist'"),
        ("index", "1.0", "index is a name openral-data and lerobot reserve"),
        ("a/b", "1.0", "cannot be a feature key"),
    ],
)
def test_refused_in_one_line_nothing_written(source: Path, tmp_path: Path, name: str, sql: str, says: str) -> None:
    out = tmp_path / "out"
    assert says in refused("features", "add", str(source), "--name", name, "--sql", sql, "--out", str(out))
    assert not out.exists()
