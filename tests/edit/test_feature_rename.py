"""`features rename --from OLD --to NEW`: the feature is under its new key everywhere (video files, info.json,
stats.json, the episodes' `videos/...` and `stats/...` columns, the data column), its packets and values copied
unchanged; lerobot 0.6.1 loads the result with the source's frames under the new key; doctor --deep finds it
healthy; reserved names, collisions and unsafe keys are refused in one line with nothing written."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest

from openral_data.doctor import check
from tests.support.curate import lerobot_items, packets, refused
from tests.support.inproc import run_inproc
from tests.support.lerobot_written import (
    ENV_STATE,
    IMAGE_CAMERA,
    LENGTHS,
    VIDEO_CAMERA,
    digest,
    write_lerobot_dataset,
)


@pytest.fixture(scope="module")
def source(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("rename") / "lerobot"
    write_lerobot_dataset(root, with_success=True, image_camera=True, environment_state=True)
    return root


def _renamed_everywhere(src: Path, out: Path, old: str, new: str) -> None:
    info, src_info = (json.loads((p / "meta/info.json").read_text()) for p in (out, src))
    assert list(info["features"]) == [new if k == old else k for k in src_info["features"]]
    assert info["features"][new] == src_info["features"][old]
    assert {k: v for k, v in info.items() if k != "features"} == {k: v for k, v in src_info.items() if k != "features"}
    stats, src_stats = (json.loads((p / "meta/stats.json").read_text()) for p in (out, src))
    assert old not in stats and stats[new].keys() == src_stats[old].keys()
    for s in stats[new]:  # the dataset's stats are merged again from the episodes': equal up to rounding
        assert np.allclose(stats[new][s], src_stats[old][s], rtol=1e-6), s
    eps, src_eps = pq.read_table(out / "meta/episodes"), pq.read_table(src / "meta/episodes")
    for col in src_eps.column_names:
        if col.startswith((f"stats/{old}/", f"videos/{old}/")):
            assert eps.column(col.replace(old, new, 1)).to_pylist() == src_eps.column(col).to_pylist(), col
    assert not [c for c in eps.column_names if f"/{old}/" in c]
    data, src_data = pq.read_table(out / "data"), pq.read_table(src / "data")
    if old in src_data.column_names:
        assert data.column(new).to_pylist() == src_data.column(old).to_pylist()
        assert old not in data.column_names
    assert not (out / "videos" / old).exists()


def test_rename_a_video_camera_moves_its_files_and_copies_its_packets(source: Path, tmp_path: Path) -> None:
    before = digest(source)
    out, new = tmp_path / "out", "observation.images.front"
    res = run_inproc("features", "rename", str(source), "--from", VIDEO_CAMERA, "--to", new, "--out", str(out))
    assert res.returncode == 0, res.stderr
    assert res.stdout.startswith(f"renamed: {out}  episodes 3  frames {sum(LENGTHS)}")
    assert check(out, deep=True) == []
    _renamed_everywhere(source, out, VIDEO_CAMERA, new)
    assert packets(out, new) == packets(source, VIDEO_CAMERA)  # bytes copied, not re-encoded
    got = lerobot_items(out, [new, "observation.state", IMAGE_CAMERA])
    want = lerobot_items(source, [VIDEO_CAMERA, "observation.state", IMAGE_CAMERA])
    for g, w in zip(got, want, strict=True):
        assert np.array_equal(g[new], w[VIDEO_CAMERA])
        assert np.array_equal(g["observation.state"], w["observation.state"])
        assert np.array_equal(g[IMAGE_CAMERA], w[IMAGE_CAMERA])
    assert digest(source) == before


def test_rename_an_image_camera_and_a_column(source: Path, tmp_path: Path) -> None:
    first, second = tmp_path / "a", tmp_path / "b"
    assert (
        run_inproc(
            "features",
            "rename",
            str(source),
            "--from",
            IMAGE_CAMERA,
            "--to",
            "observation.images.hand",
            "--out",
            str(first),
        ).returncode
        == 0
    )
    assert (
        run_inproc(
            "features", "rename", str(first), "--from", ENV_STATE, "--to", "observation.env", "--out", str(second)
        ).returncode
        == 0
    )
    assert check(second, deep=True) == []
    _renamed_everywhere(source, first, IMAGE_CAMERA, "observation.images.hand")
    _renamed_everywhere(first, second, ENV_STATE, "observation.env")
    got = lerobot_items(second, ["observation.images.hand", "observation.env", VIDEO_CAMERA])
    want = lerobot_items(source, [IMAGE_CAMERA, ENV_STATE, VIDEO_CAMERA])
    for g, w in zip(got, want, strict=True):
        assert np.array_equal(g["observation.images.hand"], w[IMAGE_CAMERA])
        assert np.array_equal(g["observation.env"], w[ENV_STATE])
        assert np.array_equal(g[VIDEO_CAMERA], w[VIDEO_CAMERA])


def test_rename_a_camera_of_our_dataset_in_place(project: Path, tmp_path: Path) -> None:
    from tests.edit.test_edit import _record

    ds = _record(project, tmp_path / "ours", 0, 2)
    wrist = packets(ds, "observation.images.wrist")
    want = lerobot_items(ds, ["observation.images.wrist", "action"])
    res = run_inproc(
        "features",
        "rename",
        str(ds),
        "--from",
        "observation.images.wrist",
        "--to",
        "observation.images.hand",
        "--in-place",
    )
    assert res.returncode == 0, res.stderr
    assert check(ds, deep=True) == []
    assert packets(ds, "observation.images.hand") == wrist
    assert (ds / ".openral/image_hist.json").is_file()  # every episode kept: the histograms stay exact
    assert "hand" in json.loads((ds / ".openral/image_hist.json").read_text())
    got = lerobot_items(ds, ["observation.images.hand", "action"])
    for g, w in zip(got, want, strict=True):
        assert np.array_equal(g["observation.images.hand"], w["observation.images.wrist"])
        assert np.array_equal(g["action"], w["action"])


@pytest.mark.parametrize(
    ("old", "new", "says"),
    [
        (VIDEO_CAMERA, "index", "index is a name openral-data and lerobot reserve"),
        (VIDEO_CAMERA, "task", "task is a name openral-data and lerobot reserve"),
        ("timestamp", "observation.t", "timestamp is a name openral-data and lerobot reserve"),
        ("action", "observation.act", "action is a name openral-data and lerobot reserve"),
        (VIDEO_CAMERA, IMAGE_CAMERA, f"already has a feature '{IMAGE_CAMERA}'"),
        ("observation.images.nope", "observation.images.x", "has no feature 'observation.images.nope'"),
        (VIDEO_CAMERA, "../escape", "cannot be a feature key"),
    ],
)
def test_refused_in_one_line_nothing_written(source: Path, tmp_path: Path, old: str, new: str, says: str) -> None:
    out = tmp_path / "out"
    line = refused("features", "rename", str(source), "--from", old, "--to", new, "--out", str(out))
    assert says in line
    assert not out.exists()
