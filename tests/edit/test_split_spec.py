"""`episodes split --spec NAME=LIST,…`: one dataset per named episode list under --out-dir, each episode's frames
as in the source (lerobot 0.6.1 loads them exactly), doctor --deep clean; overlapping parts, unknown episodes
and malformed specs refused in one line with nothing written."""

from __future__ import annotations

from pathlib import Path

import pytest

from openral_data.doctor import check
from tests.support.curate import refused
from tests.support.inproc import run_inproc
from tests.support.lerobot_written import LENGTHS, digest, loaded_episodes, same_frames, write_lerobot_dataset


@pytest.fixture(scope="module")
def source(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("spec") / "lerobot"
    write_lerobot_dataset(root, with_success=True, image_camera=True)
    return root


def test_named_lists_become_one_dataset_each(source: Path, tmp_path: Path) -> None:
    before = digest(source)
    want = loaded_episodes(source)
    out = tmp_path / "parts"
    res = run_inproc("episodes", "split", str(source), "--spec", "train=2,0,val=1", "--out-dir", str(out))
    assert res.returncode == 0, res.stderr
    assert res.stdout.splitlines() == [
        f"split: {out / 'train'}  episodes 2  frames {LENGTHS[2] + LENGTHS[0]}",
        f"split: {out / 'val'}  episodes 1  frames {LENGTHS[1]}",
    ]
    for name, episodes in [("train", [2, 0]), ("val", [1])]:
        assert check(out / name, deep=True) == []
        got = loaded_episodes(out / name)
        assert len(got) == len(episodes)
        for g, e in zip(got, episodes, strict=True):  # in the order listed
            same_frames(g, want[e])
    assert digest(source) == before


@pytest.mark.parametrize(
    ("spec", "says"),
    [
        ("train=0-1,val=1", "--spec: episode 1 is in both train and val; parts must not overlap"),
        ("train=0-5", "--spec: train: '0-5' is outside the dataset's episodes 0..2"),
        ("0-1,val=2", "does not start with NAME=EPISODES"),
        ("a=0,a=1", "names a part twice"),
        ("a=0,../x=1", "'../x' cannot be a file or folder name"),
        ("a=", "a: give NAME=EPISODES"),
    ],
)
def test_bad_specs_are_refused_in_one_line(source: Path, tmp_path: Path, spec: str, says: str) -> None:
    out = tmp_path / "parts"
    assert says in refused("episodes", "split", str(source), "--spec", spec, "--out-dir", str(out))
    assert not out.exists()


def test_spec_goes_with_out_dir_only(source: Path, tmp_path: Path) -> None:
    line = refused("episodes", "split", str(source), "--spec", "a=0", "--out", str(tmp_path / "x"))
    assert line == "error: --spec: give --out-dir, not --episodes/--out/--rest/--fractions"
