"""`formats.lerobot_v2` and `formats.dataset`: a LeRobot v2.0/v2.1 dataset read in place into the shapes the v3
readers take, and the v3 reader refusing it in one line that names `upgrade`."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from openral_data.errors import DatasetError
from openral_data.formats import lerobot_v2
from openral_data.formats.dataset import open_lerobot, summarize
from openral_data.formats.lerobot_v3.frames import episode_frames
from openral_data.formats.lerobot_v3.reader import read_info
from tests.support.legacy_v2 import COLOUR_TOL, LENGTHS, TASKS, VIDEO_CAMERA, expected_episodes, write_v2


@pytest.fixture(scope="module", params=["v2.0", "v2.1"])
def v2(request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory) -> Path:
    version = str(request.param)
    return write_v2(tmp_path_factory.mktemp(version) / "ds", version=version, image=True, names_null=True)


def test_info_tasks_episodes(v2: Path) -> None:
    ds = open_lerobot(v2)
    assert ds.legacy == json.loads((v2 / "meta/info.json").read_text())["codebase_version"]
    assert ds.tasks() == list(TASKS)
    eps = ds.episodes().to_pylist()
    starts = [sum(LENGTHS[:e]) for e in range(len(LENGTHS))]
    assert [r["episode_index"] for r in eps] == [0, 1, 2]
    assert [r["length"] for r in eps] == list(LENGTHS)
    assert [r["tasks"] for r in eps] == [[TASKS[e % 2]] for e in range(3)]
    assert [(r["dataset_from_index"], r["dataset_to_index"]) for r in eps] == [
        (s, s + n) for s, n in zip(starts, LENGTHS, strict=True)
    ]
    for r in eps:
        assert r[f"videos/{VIDEO_CAMERA}/from_timestamp"] == 0.0
        assert r[f"videos/{VIDEO_CAMERA}/to_timestamp"] == pytest.approx(r["length"] / 10)
    files = ds.data_files()
    names = [p.relative_to(v2).as_posix() for p in files]
    assert names == [f"data/chunk-000/episode_{e:06d}.parquet" for e in range(3)]
    s = summarize(v2)
    assert (s.episodes, s.frames, s.tasks, s.codebase_version) == (3, sum(LENGTHS), list(TASKS), ds.legacy)


def test_frames_read_back(v2: Path) -> None:
    """The v3 frame reader takes a v2 episode as it is: numbers exact, PNG images exact, video within h264's loss."""
    ds = open_lerobot(v2)
    want = expected_episodes(LENGTHS, video=True, image=True)
    for row in ds.episodes().to_pylist():
        e = row["episode_index"]
        got = list(episode_frames(v2, ds.info, row, ds.tasks(), ["cam", "wrist"]))
        assert len(got) == LENGTHS[e]
        for t, (frame, w) in enumerate(zip(got, want[e], strict=True)):
            assert frame.state.tolist() == w["state"] and frame.action.tolist() == w["action"]
            assert frame.task == w["task"] and frame.timestamp == pytest.approx(t / 10)
            assert (frame.images["wrist"] == w["wrist"]).all()
            assert abs(frame.images["cam"].astype(int) - w["cam"].astype(int)).max() <= COLOUR_TOL


def test_v3_reader_refuses_in_one_line(v2: Path) -> None:
    with pytest.raises(DatasetError) as err:
        read_info(v2)
    assert err.value.code == "dataset.unsupported"
    assert "openral-data upgrade" in str(err.value) and "\n" not in str(err.value)


def test_paths_stay_inside(tmp_path: Path) -> None:
    root = write_v2(tmp_path / "ds", lengths=[2], video=False)
    info = json.loads((root / "meta/info.json").read_text())
    info["data_path"] = "../../outside/episode_{episode_index:06d}.parquet"
    (root / "meta/info.json").write_text(json.dumps(info))
    with pytest.raises(DatasetError) as err:
        open_lerobot(root)
    assert err.value.code == "dataset.unsafe"


@pytest.mark.parametrize(
    ("name", "text", "wanted"),
    [
        ("episodes.jsonl", '{"episode_index": 0, "length": 2}\n{"episode_index": 0, "length": 1}\n', "twice"),
        ("episodes.jsonl", '{"episode_index": 0, "length": -1}\n', "integers >= 0"),
        ("episodes.jsonl", "{not json\n", "line 1: invalid JSON"),
        ("tasks.jsonl", '{"task_index": 3, "task": "x"}\n', "task_index"),
        ("tasks.jsonl", "[1]\n", "not a JSON object"),
    ],
)
def test_bad_jsonl_is_one_line(tmp_path: Path, name: str, text: str, wanted: str) -> None:
    root = write_v2(tmp_path / "ds", lengths=[2], video=False)
    (root / "meta" / name).write_text(text)
    ds = open_lerobot(root)
    with pytest.raises(DatasetError) as err:
        ds.tasks() if name == "tasks.jsonl" else ds.episodes()
    assert wanted in str(err.value) and "\n" not in str(err.value), str(err.value)


def test_jsonl_is_bounded(tmp_path: Path) -> None:
    path = tmp_path / "big.jsonl"
    path.write_text('{"a": 1}\n' * 100)
    with pytest.raises(DatasetError, match="larger than"):
        lerobot_v2.read_jsonl(path, limit=50)
