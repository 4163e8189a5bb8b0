"""A single-process recording (a scene's, a HAL's, and so `generate`'s) checks, right after its first episode is
committed, that lerobot 0.6.1 loads what it is publishing (`record.output.check_first_episode`); a refusal is one
line and takes away everything the new recording wrote (#45)."""

from __future__ import annotations

import json
import logging
import threading
from pathlib import Path

import pytest

from openral_data.errors import DatasetError
from openral_data.formats.lerobot_v3 import loadable
from openral_data.record.hal import HalRecordOptions, record_hal
from openral_data.record.output import check_first_episode
from tests.support.inproc import run_inproc
from tests.support.scenes import mock_scene, write_yaml

CHECKED = "first episode loadable by lerobot"


def _checked(caplog: pytest.LogCaptureFixture, out: Path) -> list[str]:
    return [r.getMessage() for r in caplog.records if CHECKED in r.getMessage() and str(out) in r.getMessage()]


def test_a_new_recording_is_checked_once_and_a_resume_not_at_all(
    tmp_path: Path, publish_load: None, monkeypatch: pytest.MonkeyPatch
) -> None:
    warmed: list[bool] = []  # lerobot's import, paid beside the scene's build (not inside the recording)
    real_warm_up = loadable.warm_up

    def warm_up() -> None:
        warmed.append(True)
        real_warm_up()

    monkeypatch.setattr(loadable, "warm_up", warm_up)
    scene = write_yaml(tmp_path / "s.yaml", mock_scene(max_steps=4, n_episodes=2))
    out = tmp_path / "ds"
    r = run_inproc("-v", "record", "--scene", str(scene), "--out", str(out), "--codec", "h264")
    assert r.returncode == 0, r.stderr
    assert r.stderr.count(CHECKED) == 1, r.stderr  # after the first commit only: the second has the same writer
    assert warmed == [True]
    assert len(list((out / "meta" / "episodes").rglob("*.parquet"))) >= 1
    r = run_inproc("-v", "record", "--scene", str(scene), "--out", str(out), "--resume", "--n-episodes", "3")
    assert r.returncode == 0, r.stderr
    assert CHECKED not in r.stderr  # a resume never checks (nor removes) a dataset it did not start
    assert warmed == [True]  # ... so it does not import lerobot for a check either


@pytest.mark.slow
def test_a_hal_recording_is_checked(
    tmp_path: Path, caplog: pytest.LogCaptureFixture, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Checked once, after its first commit; lerobot's import for that check is started beside the robot's
    connection, on a thread of its own, and done before the first episode (not between the first two)."""
    warmed: list[tuple[str, int]] = []  # (the thread it ran on, the episodes committed when it was done)
    out = tmp_path / "hal"
    real_warm_up = loadable.warm_up

    def warm_up() -> None:
        real_warm_up()
        warmed.append((threading.current_thread().name, len(list(out.glob("meta/episodes/*/*.parquet")))))

    monkeypatch.setattr(loadable, "warm_up", warm_up)
    with caplog.at_level(logging.INFO, logger="openral_data"):
        s = record_hal(
            HalRecordOptions(
                robot="ur5e", rskill="sweep-ur5e", fps=20, n_episodes=1, max_steps=3, out=out, codec="h264",
                operator="success",
            )
        )  # fmt: skip
    assert len(s.episodes) == 1
    assert len(_checked(caplog, out)) == 1
    assert warmed == [("warm-up-lerobot", 0)], warmed


def test_an_unloadable_first_episode_is_refused_in_one_line_and_nothing_stays(tmp_path: Path) -> None:
    scene = write_yaml(tmp_path / "s.yaml", mock_scene(max_steps=4, n_episodes=1))
    out = tmp_path / "ds"
    r = run_inproc(
        "record", "--scene", str(scene), "--out", str(out), "--codec", "h264", "--format", "lerobot,mcap", "-q"
    )
    assert r.returncode == 0, r.stderr
    assert (out / "mcap").is_dir()
    info_path = out / "meta" / "info.json"
    info = json.loads(info_path.read_text())
    del info["features"]["task_index"]  # what lerobot's loader reads for every frame
    info_path.write_text(json.dumps(info))
    closed: list[bool] = []
    with pytest.raises(DatasetError) as refused:
        check_first_episode(out, ("lerobot", "mcap"), lambda: closed.append(True))
    err = refused.value
    assert err.code == "dataset.unloadable" and "\n" not in str(err)
    assert "task_index" in str(err) and "not published" in str(err)
    assert closed == [True]  # the sinks closed before anything is removed
    assert [p.name for p in out.iterdir()] == [".openral"]  # the episode, its videos and bags gone
    assert list((out / ".openral").iterdir()) == []
