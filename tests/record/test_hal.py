"""`record --hal` end to end (slow): the UR5e twin into LeRobot v3 + MCAP loaded by lerobot 0.6.1 and rosbags,
a sim scene behind the HAL, the SO-100 adapter — lerobot's real driver — on a SIMULATED Feetech bus, the SO arms'
MuJoCo twin, and a real-arm (simulated bus) recording replayed on that twin."""

from __future__ import annotations

import json
import logging
from pathlib import Path

import numpy as np
import pytest

# ConfigError raises are matched by message on purpose: the file and field it names are the point
from openral_data.errors import ConfigError, DiskError, HalError
from openral_data.record.hal import HalRecordOptions, record_hal
from openral_data.replay.actions import ActionReplayer
from openral_data.replay.rebuild import SceneView, rebuild
from openral_data.replay.recorded import RecordedDataset
from openral_data.types import Observation, StepResult
from tests.support.cli import run_cli
from tests.support.faults import Faults, inject
from tests.support.feetech_bus import SimulatedFeetechBus, calibrated_so_project
from tests.support.hal import episode_infos, frames_table
from tests.support.mcap import check_bag
from tests.support.timing import TIMED

pytestmark = [pytest.mark.slow, TIMED]


def test_twin_recording_loads_in_lerobot_and_mcap_keeps_real_stamps(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    out = tmp_path / "ds"
    with caplog.at_level(logging.INFO, logger="openral_data"):
        s = record_hal(
            HalRecordOptions(
                robot="ur5e", rskill="sweep-ur5e", fps=20, n_episodes=2, max_steps=15, out=out,
                codec="h264", formats=("lerobot", "mcap"), operator="success,failure@9",
            )
        )  # fmt: skip
    assert [r.length for r in s.episodes] == [15, 9] and [r.success for r in s.episodes] == [True, False]
    logged = [(r.__dict__["length"], r.__dict__["outcome"]) for r in caplog.records if hasattr(r, "outcome")]
    assert logged == [(15, "success"), (9, "failure")]  # -v's episode lines, as for a scene
    [totals] = [r.__dict__ for r in caplog.records if hasattr(r, "saved")]
    assert (totals["saved"], totals["frames"]) == (2, 24)
    assert all(r.accounted() for r in s.all_reports)
    ds = LeRobotDataset("local/hal", root=out, video_backend="pyav")
    assert len(ds) == 24 and ds.fps == 20
    real = []
    for i in range(len(ds)):
        item = ds[i]
        t = int(item["frame_index"])
        assert abs(float(item["timestamp"]) - t / 20) < 1e-6  # frame-aligned, as lerobot expects
        assert item["observation.images.wrist"].shape == (3, 128, 128)
        real.append(float(item["openral.real_timestamp"]))
        assert float(item["openral.real_timestamp"]) >= float(item["openral.tick"]) / 20 - 1e-4
    infos = [json.loads(x)["hal"] for x in ds.meta.episodes["openral.episode_info"]]
    assert [i["verdict"] for i in infos] == ["success", "failure"]

    # the MCAP bags carry the real monotonic stamps (episode start + real_timestamp), not frame-aligned ones
    cols = frames_table(out)
    for e in (0, 1):
        bag = out / "mcap" / f"episode_{e:06d}"
        msgs = check_bag(bag)
        joint = next(v for topic, v in msgs.items() if "joint" in topic)
        stamps = np.array([ns for ns, _ in joint], dtype=np.int64)
        rel = (stamps - stamps[0]) / 1e9
        mine = np.array(
            [r for r, ep in zip(cols["openral.real_timestamp"], cols["episode_index"], strict=True) if ep == e]
        )
        assert np.allclose(rel, mine - mine[0], atol=1e-5)
        assert not np.allclose(rel, np.arange(len(rel)) / 20, atol=1e-4), "MCAP stamps must be the real ones"


def test_a_commit_failing_behind_the_recording_names_only_the_episodes_kept(tmp_path: Path) -> None:
    """`record --hal` commits each episode behind the recording, after its end was reported: when episode 1's commit
    fails there (the disk full from its first write on), the run ends with one line that names episode 0 as the only
    one kept (not every episode whose end was reached), and that is what lerobot loads."""
    out = tmp_path / "ds"
    faults = Faults(fail_at=1)

    class ArmAfterEpisode0(logging.Handler):
        def emit(self, record: logging.LogRecord) -> None:  # episode 0 is committed (and checked) when it is logged
            if record.__dict__.get("episode") == 0 and hasattr(record, "outcome"):
                faults.armed = True

    logger = logging.getLogger("openral_data")
    handler, level = ArmAfterEpisode0(), logger.level
    logger.addHandler(handler)
    logger.setLevel(logging.INFO)
    try:
        with inject(faults), pytest.raises(DiskError) as excinfo:
            record_hal(
                HalRecordOptions(
                    robot="ur5e", rskill="sweep-ur5e", fps=20, n_episodes=3, max_steps=8, out=out, codec="h264",
                    operator="success",
                )
            )  # fmt: skip
    finally:
        logger.removeHandler(handler)
        logger.setLevel(level)
    assert str(excinfo.value) == (
        f"{out}: no space left on device while committing episode 1; "
        "episode 0 is kept (free space, then record --resume)"
    )
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    ds = LeRobotDataset("local/hal", root=out, video_backend="pyav")  # as the failure left it, no repair first
    assert [int(n) for n in ds.meta.episodes["length"]] == [8] and len(ds) == 8


def test_sim_scene_behind_the_hal(tmp_path: Path) -> None:
    out = tmp_path / "scene"
    s = record_hal(
        HalRecordOptions(
            robot="franka_panda", rskill="scripted-push", scene="tabletop_push", fps=20, n_episodes=1,
            max_steps=30, out=out, codec="h264",
        )
    )  # fmt: skip
    assert s.episodes[0].length <= 30 and s.all_reports[0].accounted()
    cols = frames_table(out)
    assert "next.reward" in cols and len(cols["observation.state"][0]) == 8
    assert "openral.real_timestamp" in cols and all(a == 0 for a in cols["openral.sample_age.front"])
    assert (out / "videos" / "observation.images.front").is_dir()


def _so_project(project: Path, robot: str) -> Path:
    """The SO manifest pointing at a calibration file like `lerobot-calibrate` writes."""
    return calibrated_so_project(project, robot)


@pytest.fixture
def so100_project(project: Path) -> Path:
    return _so_project(project, "so100_follower")


@pytest.mark.parametrize("robot", ["so100_follower", "so101_follower"])
def test_so_arm_through_lerobots_driver_on_a_simulated_bus(project: Path, tmp_path: Path, robot: str) -> None:
    """SIMULATED hardware: lerobot's SOFollower + scservo SDK + pyserial talk to a pty servo simulator."""
    _so_project(project, robot)
    out = tmp_path / robot
    with SimulatedFeetechBus(list(range(1, 7))) as bus:
        s = record_hal(
            HalRecordOptions(
                robot=robot, rskill="sweep-so-arm", mode="real", port=bus.port, fps=10,
                n_episodes=1, max_steps=15, out=out, codec="h264", operator="success",
            )
        )  # fmt: skip
        goal_writes = {i: sv.writes for i, sv in bus.servos.items()}
        present = {i: sv.get16("present") for i, sv in bus.servos.items()}
    assert s.episodes[0].length == 15 and s.episodes[0].success is True
    assert all(n >= 15 for n in goal_writes.values()), goal_writes  # every frame's command reached every servo
    cols = frames_table(out)
    state = np.array(cols["observation.state"])
    action = np.array(cols["action"])
    assert state.shape == (15, 6)
    assert np.allclose(state[0], [0, 0, 0, 0, 0, 50], atol=0.2)  # the calibrated middle, gripper half open
    # the servos follow: each reading is close to the previous frame's command
    assert np.abs(state[1:, :5] - action[:-1, :5]).max() < 3.0
    assert present[1] != 2048  # the simulated shoulder_pan moved away from the middle
    assert episode_infos(out)[0]["hal"]["verdict"] == "success"


def test_so100_refuses_to_run_uncalibrated(so100_project: Path, tmp_path: Path) -> None:
    differs = r"hardware\.calibration_dir: the motors' calibration differs"
    with (
        SimulatedFeetechBus(list(range(1, 7)), range_min=900) as bus,  # the motors disagree with the file
        pytest.raises(HalError, match=differs) as excinfo,  # the field named (calibration_dir) is matched too
    ):
        record_hal(
            HalRecordOptions(
                robot="so100_follower", rskill="sweep-so-arm", mode="real", port=bus.port, out=tmp_path / "a"
            )
        )
    assert excinfo.value.code == "hal.calibration"
    (so100_project / "robots" / "so100_follower" / "calibration" / "so100_follower.json").unlink()
    with pytest.raises(ConfigError, match=r"no calibration .*lerobot-calibrate"):
        record_hal(
            HalRecordOptions(
                robot="so100_follower", rskill="sweep-so-arm", mode="real", port="/dev/null", out=tmp_path / "b"
            )
        )
    assert not (tmp_path / "a").exists() and not (tmp_path / "b").exists()


@pytest.mark.parametrize("robot", ["so100_follower", "so101_follower"])
def test_so_arm_twin_records_what_the_real_arm_would(tmp_path: Path, robot: str) -> None:
    """`record --hal so100_follower --mode sim`: the same rSkill and loop as the real arm, in the real arm's units."""
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    out = tmp_path / robot
    s = record_hal(
        HalRecordOptions(
            robot=robot, rskill="sweep-so-arm", fps=10, n_episodes=1, max_steps=15, out=out, codec="h264",
            operator="success",
        )
    )  # fmt: skip
    assert s.episodes[0].length == 15 and s.episodes[0].success is True
    ds = LeRobotDataset("local/so-twin", root=out, video_backend="pyav")
    assert len(ds) == 15 and ds.meta.robot_type == robot
    state = np.stack([ds[i]["observation.state"].numpy() for i in range(15)])
    action = np.stack([ds[i]["action"].numpy() for i in range(15)])
    # the twin starts at the MJCF zero = the middle of the calibrated range (0 degrees), jaw open (100)
    assert np.allclose(state[0], [0, 0, 0, 0, 0, 100], atol=0.5)
    assert 5.0 < np.abs(action[:, :5]).max() <= 10.0 + 1e-3  # the sweep's amplitude, in degrees
    assert np.abs(state[1:, :5] - action[:-1, :5]).max() < 3.0  # the servos follow, as the real ones do
    assert 15.0 < state[-1, 5] < 70.0  # the jaw followed the 20..60 gripper sweep from open
    info = json.loads(ds.meta.episodes["openral.initial_state"][0])
    assert info["hal"] == "mujoco_twin" and info["state"] == pytest.approx(state[0].tolist(), abs=0.5)


def test_real_arm_recording_replays_on_the_twin(project: Path, tmp_path: Path) -> None:
    """A recording of the real arm (SIMULATED bus) replays on the MuJoCo twin: the twin follows its joint targets."""
    _so_project(project, "so100_follower")
    out = tmp_path / "real"
    with SimulatedFeetechBus(list(range(1, 7))) as bus:
        record_hal(
            HalRecordOptions(
                robot="so100_follower", rskill="sweep-so-arm", mode="real", port=bus.port, fps=10,
                n_episodes=1, max_steps=20, out=out, codec="h264", operator="success",
            )
        )  # fmt: skip
    dataset = RecordedDataset(out)
    assert dataset.hal_recording()
    episode = dataset.episode(0)
    assert episode.initial_state is not None
    assert episode.initial_state["state"] == pytest.approx(episode.states[0].tolist(), abs=0.5)
    built = rebuild(dataset, view=SceneView(cameras=()))
    after: list[np.ndarray] = []

    def seen(obs: Observation, action: np.ndarray, result: StepResult, done: bool) -> None:
        after.append(np.asarray(result.observation.state))

    try:
        assert built.scene.scene.type == "mujoco_twin" and built.scene.scene.fps == 10
        replayed = ActionReplayer(built.env, tolerance=5.0).replay(episode, seen)
    finally:
        built.env.close()
    assert replayed.steps == 20 and len(after) == 20
    follow = np.abs(np.array(after)[:, :5] - episode.actions[:, :5])
    assert follow.max() < 2.0, follow.max()  # degrees: each target reached within the 0.1 s step
    # and close to what the real arm did: within 5 (degrees; gripper units, its jaw servo is slower)
    assert replayed.first_divergence_frame is None
    assert replayed.state_abs is not None and replayed.state_abs[:, :5].max() < 2.0
    assert replayed.state_abs[1:, :5].max() > 0  # a simulation, not a copy of the recording

    res = tmp_path / "res"
    r = run_cli("replay", str(out), "--tolerance", "5", "--out", str(res), "--json")
    assert r.returncode == 0, r.stderr
    summary = json.loads(r.stdout)
    assert summary["mode"] == "actions" and summary["episodes"] == 1 and summary["diverged_episodes"] == {}
    assert 0 < summary["divergence_max"] < 10.0
    assert summary["success_recorded"] == 1 and summary["success_replayed"] == 0  # the twin has no task
