"""`openral-data export DATASET --to rlds|robomimic OUT` (#47): a LeRobot dataset with two splits, a language
instruction per episode, rewards and success written as an RLDS build folder and as a robomimic HDF5 file. Each is
read by a reader that is not the writer (our RLDS reader, h5py against robomimic's documented layout) and equals
the dataset's numbers exactly and its pictures within JPEG's tolerance; converted back to LeRobot, the numbers, the
tasks and the splits come back (LeRobot -> RLDS -> LeRobot, LeRobot -> robomimic -> LeRobot)."""

from __future__ import annotations

import json
from pathlib import Path

import h5py
import numpy as np
import pytest

from tests.cli.test_json import parse
from tests.support.exported import SPLITS, Episode, close_pictures, source_episodes, splits_dataset
from tests.support.inproc import run_inproc


@pytest.fixture(scope="module")
def dataset(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return splits_dataset(tmp_path_factory.mktemp("export"))


@pytest.fixture(scope="module")
def episodes(dataset: Path) -> list[Episode]:
    return source_episodes(dataset)


def _back(out: Path, tmp: Path, *fps: str) -> list[Episode]:
    """`out` converted back to LeRobot v3 by `convert` (our source kinds), read as `source_episodes` does."""
    back = tmp / "back"
    run = run_inproc("convert", str(out), str(back), "--codec", "h264", *fps)
    assert run.returncode == 0, run.stderr
    return source_episodes(back)


def _same_numbers(got: list[Episode], want: list[Episode]) -> None:
    assert len(got) == len(want)
    for g, w in zip(got, want, strict=True):
        assert np.array_equal(g.state, w.state) and np.array_equal(g.action, w.action)
        assert np.array_equal(g.reward, w.reward) and np.array_equal(g.success, w.success)
        assert g.task == w.task
        for camera, pictures in w.pictures.items():
            close_pictures(g.pictures[camera], pictures, mean=4.0)  # JPEG, then h264 again


def test_rlds_export_reads_back_and_round_trips(dataset: Path, episodes: list[Episode], tmp_path: Path) -> None:
    from openral_data.formats.rlds import RldsSource

    out = tmp_path / "rlds"
    run = run_inproc("export", str(dataset), "--to", "rlds", str(out), "--json")
    assert run.returncode == 0, run.stderr
    doc = parse(run.stdout, "convert lerobot-to-mcap")  # the fields docs/scripting.md documents
    assert doc["direction"] == "lerobot-to-rlds" and doc["episodes"] == 5 and doc["frames"] == 12
    info = json.loads((out / "dataset_info.json").read_text())
    assert [(s["name"], s["shardLengths"]) for s in info["splits"]] == [("train", ["3"]), ("val", ["2"])]
    read = list(RldsSource(out).episodes())
    assert [e.meta.split for e in read] == ["train"] * 3 + ["val"] * 2
    for got, want in zip(read, episodes, strict=True):
        n = got.length
        assert n == len(want.state) and got.meta.language == want.task
        assert got.meta.attrs["episode_metadata/episode_index"] == want.index
        assert np.array_equal(got.read("steps/observation/state", 0, n), want.state)
        assert np.array_equal(got.read("steps/action", 0, n), want.action)
        assert np.array_equal(got.read("steps/reward", 0, n), want.reward)
        assert got.read("steps/is_first", 0, n).tolist() == [True] + [False] * (n - 1)
        assert got.read("steps/is_last", 0, n).tolist() == [False] * (n - 1) + [True]
        assert got.read("steps/is_terminal", 0, n).tolist() == want.success.tolist()
        for camera, pictures in want.pictures.items():
            close_pictures(got.read(f"steps/observation/{camera}", 0, n), pictures)
    back = _back(out, tmp_path, "--fps", "5")
    _same_numbers(back, episodes)
    assert json.loads((tmp_path / "back/meta/info.json").read_text())["splits"] == SPLITS


def test_robomimic_export_layout_and_round_trip(dataset: Path, episodes: list[Episode], tmp_path: Path) -> None:
    out = tmp_path / "demos.hdf5"
    run = run_inproc("export", str(dataset), "--to", "robomimic", str(out))
    assert run.returncode == 0, run.stderr
    with h5py.File(out, "r") as f:
        data = f["data"]
        assert int(data.attrs["total"]) == sum(len(e.state) for e in episodes)
        env = json.loads(data.attrs["env_args"])
        assert env["env_kwargs"]["control_freq"] == 5 and {"env_name", "type"} <= set(env)
        assert sorted(data) == [f"demo_{k}" for k in range(5)]
        for k, want in enumerate(episodes):
            demo = data[f"demo_{k}"]
            n = len(want.state)
            assert int(demo.attrs["num_samples"]) == n and int(demo.attrs["episode_index"]) == want.index
            assert json.loads(demo.attrs["ep_meta"]) == {"lang": want.task}
            assert demo["actions"].dtype == np.float32 and np.array_equal(demo["actions"][()], want.action)
            assert np.array_equal(demo["obs/state"][()], want.state)
            assert np.array_equal(demo["rewards"][()], want.reward)
            assert demo["dones"][()].tolist() == [0] * (n - 1) + [1]
            for camera, pictures in want.pictures.items():
                stored = demo[f"obs/{camera}_image"]
                assert stored.dtype == np.uint8 and np.array_equal(stored[()], pictures)  # decoded, uint8 HWC
        masks = {k: [v.decode() for v in f["mask"][k][()]] for k in f["mask"]}
        assert masks == {"train": ["demo_0", "demo_1", "demo_2"], "valid": ["demo_3", "demo_4"]}
    back = _back(out, tmp_path)
    _same_numbers(back, episodes)
    assert json.loads((tmp_path / "back/meta/info.json").read_text())["splits"] == {"train": "0:3", "valid": "3:5"}


def test_export_refuses_in_one_line(dataset: Path, tmp_path: Path) -> None:
    """An existing OUT, an unknown format, an option the format does not take, episodes the dataset does not have
    and a dataset with broken splits: one line, exit 2, nothing written or changed."""
    taken = tmp_path / "taken.hdf5"
    taken.write_bytes(b"mine")
    full = tmp_path / "full"
    full.mkdir()
    (full / "keep.txt").write_text("mine")
    broken = tmp_path / "broken"
    run_inproc("episodes", "split", str(dataset), "--episodes", "0-4", "--out", str(broken))
    info = json.loads((broken / "meta/info.json").read_text())
    (broken / "meta/info.json").write_text(json.dumps({**info, "splits": {"train": "0-3"}}))
    cases = [
        ((str(dataset), "--to", "robomimic", str(taken)), "OUT exists; refusing to overwrite it"),
        ((str(dataset), "--to", "rlds", str(full)), "OUT exists and is not empty"),
        ((str(dataset), "--to", "tfds", str(tmp_path / "a")), "--to: 'tfds' is not one of rlds, robomimic, mcap"),
        ((str(dataset), "--to", "robomimic", str(tmp_path / "b.hdf5"), "--image-format", "png"), "--image-format"),
        ((str(dataset), "--to", "rlds", str(tmp_path / "c"), "--episodes", "7"), "--episodes"),
        ((str(broken), "--to", "rlds", str(tmp_path / "d")), "splits: train: '0-3' is not 'start:end'"),
        ((str(dataset), "--to", "mcap", str(tmp_path / "e"), "--workers", "2"), "--workers: MCAP is exported in one"),
        ((str(dataset), "--to", "rlds", str(tmp_path / "f"), "--workers", "0"), "--workers must be >= 1"),
    ]
    for args, message in cases:
        run = run_inproc("export", *args)
        lines = run.stderr.strip().splitlines()
        assert run.returncode == 2 and len(lines) == 1 and lines[0].startswith("error: "), run.stderr
        assert message in lines[0], lines[0]
    assert taken.read_bytes() == b"mine" and [p.name for p in full.iterdir()] == ["keep.txt"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["broken", "full", "taken.hdf5"]


def test_episodes_subset(dataset: Path, episodes: list[Episode], tmp_path: Path) -> None:
    """`--episodes` picks by the dataset's own numbers; each episode keeps its number and its split."""
    from openral_data.formats.rlds import RldsSource

    out = tmp_path / "some"
    run = run_inproc("export", str(dataset), "--to", "rlds", str(out), "--episodes", "1,4", "--image-format", "png")
    assert run.returncode == 0, run.stderr
    read = list(RldsSource(out).episodes())
    assert [(e.meta.split, e.meta.attrs["episode_metadata/episode_index"]) for e in read] == [("train", 1), ("val", 4)]
    pictures = read[1].read("steps/observation/wrist", 0, read[1].length)
    assert np.array_equal(pictures, episodes[4].pictures["wrist"])  # PNG: the decoded frames exactly
    bags = tmp_path / "bags"  # --to mcap: what `convert DATASET DST` writes, one bag an episode
    run = run_inproc("export", str(dataset), "--to", "mcap", str(bags), "--episodes", "3", "--json")
    assert run.returncode == 0 and json.loads(run.stdout)["direction"] == "lerobot-to-mcap", run.stderr
    assert [p.name for p in bags.iterdir()] == ["episode_000003"]


@pytest.mark.slow  # worker processes start on a loaded 2-core machine
def test_workers_write_the_same(dataset: Path, tmp_path: Path) -> None:
    """`--workers 2`: RLDS in two shards a split, robomimic in two parts, holding what one process writes."""
    from openral_data.formats.rlds import RldsSource

    for to, name in (("rlds", "r"), ("robomimic", "m.hdf5")):
        for workers in ("1", "2"):
            run = run_inproc(
                "export", str(dataset), "--to", to, str(tmp_path / f"{workers}{name}"), "--workers", workers
            )
            assert run.returncode == 0, run.stderr
    assert len(list((tmp_path / "2r").glob("dataset_2r-*.tfrecord-*-of-00002"))) == 4  # 2 splits, 2 shards each
    one, two = (list(RldsSource(tmp_path / f"{w}r").episodes()) for w in "12")
    assert [(e.meta.split, e.meta.attrs) for e in one] == [(e.meta.split, e.meta.attrs) for e in two]
    for a, b in zip(one, two, strict=True):
        assert all(np.array_equal(a.read(s.key, 0, a.length), b.read(s.key, 0, b.length)) for s in a.specs())
    with h5py.File(tmp_path / "1m.hdf5") as f1, h5py.File(tmp_path / "2m.hdf5") as f2:
        keys: list[str] = []
        f1.visit(keys.append)
        seen: list[str] = []
        f2.visit(seen.append)
        assert keys == seen
        for key in keys:
            if isinstance(f1[key], h5py.Dataset):
                assert np.array_equal(f1[key][()], f2[key][()]), key
            assert dict(f1[key].attrs) == dict(f2[key].attrs) or key == "data", key
