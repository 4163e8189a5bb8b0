"""`record --hal ROBOT --policy PATH`: a lerobot 0.6.1 checkpoint drives a robot through its HAL, as
`lerobot-record --robot.type=so101_follower --policy.path=...` does. The contract is the robot manifest's own
joints; the checkpoint's features are checked against it (and the robot's cameras) before the robot connects.

SIMULATED hardware: the SO-101 follower is lerobot's own driver on the simulated Feetech bus
(tests/support/feetech_bus.py) and its camera lerobot's OpenCVCamera reading a lossless video fed through a named
pipe at its frame rate (tests/producers/test_opencv_camera.py)."""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow.parquet as pq
import pytest
import yaml

from tests.producers.test_opencv_camera import H, W, feed, source_frame, write_video
from tests.support.checkpoint import lerobot_actions, make_act_checkpoint, raw_images
from tests.support.feetech_bus import SO_MOTORS, SimulatedFeetechBus, calibrated_so_project
from tests.support.hal import episode_infos
from tests.support.inproc import Run, run_inproc

ROBOT = "so101_follower"
AWAY = 8.0  # degrees (jaw: units) the checkpoint's actions lie from its states
HALF_OPEN = np.array([0, 0, 0, 0, 0, 50])  # the simulated arm's start: the middle, the jaw half open


def _with_front_camera(project: Path, source: Path) -> Path:
    """The calibrated SO-101 manifest in `project` with a `front` OpenCV camera reading `source`; the manifest."""
    calibrated_so_project(project, ROBOT)
    path = project / "robots" / ROBOT / "robot.yaml"
    manifest = yaml.safe_load(path.read_text())
    camera = {"type": "opencv", "index_or_path": str(source), "width": W, "height": H, "warmup_s": 0}
    manifest["hardware"]["cameras"] = {"front": camera}
    path.write_text(yaml.safe_dump(manifest, sort_keys=False))
    return path


@pytest.fixture(scope="module")
def so101_checkpoint(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """An ACT checkpoint made (by lerobot's own classes) on a small lerobot-written SO-101 dataset: state and action
    the arm's 6 joints (a few degrees about the middle, the jaw about half open; the actions AWAY from them), one
    `front` camera at HxW."""
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    base = tmp_path_factory.mktemp("so101-act")
    names = list(SO_MOTORS)
    ds = LeRobotDataset.create(
        "test/so101",
        fps=10,
        root=base / "ds",
        robot_type=ROBOT,
        use_videos=False,
        features={
            "observation.images.front": {
                "dtype": "image",
                "shape": (H, W, 3),
                "names": ["height", "width", "channels"],
            },
            "observation.state": {"dtype": "float32", "shape": (6,), "names": names},
            "action": {"dtype": "float32", "shape": (6,), "names": names},
        },
    )
    try:
        for t in range(6):
            state = (2.0 * np.sin(np.arange(6) + t) + HALF_OPEN).astype(np.float32)
            action = state + np.float32(AWAY)  # the policy asks for a pose away from the start: the arm must move
            frame = {"observation.images.front": source_frame(t), "observation.state": state, "action": action}
            ds.add_frame({**frame, "task": "sweep"})
        ds.save_episode()
    finally:
        ds.finalize()
    return make_act_checkpoint(base / "ds", base / "act")


def _record(bus: SimulatedFeetechBus, checkpoint: Path, out: Path, *extra: str) -> Run:
    args = ["record", "--hal", ROBOT, "--mode", "real", "--port", bus.port, "--policy", str(checkpoint)]
    return run_inproc(*args, "--fps", "10", "--out", str(out), "--vcodec", "h264", *extra)


@pytest.mark.slow
def test_a_checkpoint_drives_the_arm_as_lerobots_own_policy(
    project: Path, so101_checkpoint: Path, tmp_path: Path
) -> None:
    """Each recorded action is what lerobot's own loaded policy computes on the recorded observation (the state
    from the dataset, the camera's frames from the lossless MCAP copy), unclipped by the safety filter; the
    follower's servos move toward the actions; each episode says the checkpoint drove."""
    pipe = tmp_path / "front.nut"
    os.mkfifo(pipe)
    _with_front_camera(project, pipe)
    feed(pipe, write_video(tmp_path / "source.nut"))
    out = tmp_path / "rec"
    with SimulatedFeetechBus(list(range(1, 7))) as bus:
        done = _record(
            bus, so101_checkpoint, out, "--n-episodes", "2", "--max-steps", "8", "--format", "lerobot,mcap",
            "--image-format", "raw", "--json",
        )  # fmt: skip
        present = {i: sv.get16("present") for i, sv in bus.servos.items()}
    assert done.returncode == 0, done.stderr
    summary = json.loads(done.stdout)
    assert summary["episodes"] == 2 and summary["safety_interventions"] == 0  # the proposals went out unclipped
    table = pq.read_table(sorted((out / "data").rglob("*.parquet"))[0])
    episodes = table.column("episode_index").to_numpy()
    states = np.stack(table.column("observation.state").to_numpy(zero_copy_only=False)).astype(np.float32)
    actions = np.stack(table.column("action").to_numpy(zero_copy_only=False)).astype(np.float32)
    task = f"lerobot checkpoint {so101_checkpoint}"
    for e in (0, 1):
        rows = episodes == e
        assert rows.sum() == 8
        images = raw_images(out / "mcap" / f"episode_{e:06d}", "front")
        assert len({img.tobytes() for img in images}) > 1  # the camera delivered moving frames
        want = lerobot_actions(so101_checkpoint, states[rows], images, task)
        assert np.ptp(want, axis=0).max() > 1e-3  # the actions move: the frames matter
        np.testing.assert_allclose(actions[rows], want, rtol=1e-5, atol=1e-5)
        # the follower follows: it ends where the policy sent it (within a servo step or two), from afar in episode 0
        assert np.abs(states[rows][-1] - actions[rows][-2]).max() < 1.0, (states[rows], actions[rows])
    assert np.abs(states[episodes == 0][0] - actions[episodes == 0][0]).min() > AWAY / 2  # it started elsewhere
    assert present != dict.fromkeys(present, 2048)  # the simulated servos left the middle
    infos = episode_infos(out)
    assert [i["operator"] for i in infos] == ["policy:act", "policy:act"]
    again = run_inproc("replay", str(out), "--tolerance", "5", "--out", str(tmp_path / "res"), "--json")
    assert again.returncode == 0, again.stderr  # the recording replays on the arm's twin like any other
    assert json.loads(again.stdout)["episodes"] == 2


def _fake_checkpoint(
    folder: Path, state: int = 6, action: int = 6, cameras: dict[str, Any] | None = None, **stored: Any
) -> Path:
    """A checkpoint folder whose config states these features (the weights a placeholder: the fit is checked from
    config.json alone, before lerobot loads anything)."""
    inputs: dict[str, Any] = {"observation.state": {"type": "STATE", "shape": [state]}}
    for name, shape in (cameras or {}).items():
        inputs[f"observation.images.{name}"] = {"type": "VISUAL", "shape": shape}
    config = {
        **stored,  # e.g. a stored fps
        "type": "act",
        "input_features": inputs,
        "output_features": {"action": {"type": "ACTION", "shape": [action]}},
    }
    folder.mkdir()
    (folder / "config.json").write_text(json.dumps(config))
    (folder / "model.safetensors").write_bytes(b"")
    return folder


def _refused(run: Run, needle: str) -> None:
    assert run.returncode == 2, run.stderr
    assert run.stderr.startswith("error: ") and run.stderr.count("\n") == 1, run.stderr
    assert needle in run.stderr, run.stderr


def test_a_checkpoint_that_does_not_fit_the_robot_is_one_line_before_it_connects(project: Path, tmp_path: Path) -> None:
    manifest = _with_front_camera(project, tmp_path / "no-such-camera.nut")
    robot = f"robot {manifest}"
    cases = {
        "action7": (
            _fake_checkpoint(tmp_path / "a7", action=7, cameras={"front": [3, H, W]}),
            f"output_features.action: shape [7] but {robot} takes actions of 6",
        ),
        "state5": (
            _fake_checkpoint(tmp_path / "s5", state=5),
            f"input_features.observation.state: shape [5] but {robot} has a state of 6",
        ),
        "top": (
            _fake_checkpoint(tmp_path / "top", cameras={"top": [3, H, W]}),
            f"input_features.observation.images.top: camera 'top' but {robot} has ['front']",
        ),
        "size": (
            _fake_checkpoint(tmp_path / "size", cameras={"front": [3, 96, 128]}),
            f"input_features.observation.images.front.shape: 96x128 (HxW) but {robot} records {H}x{W}",
        ),
        "fps": (_fake_checkpoint(tmp_path / "fps", fps=30), f"fps: 30 but {robot} runs at 10 fps"),
    }
    with SimulatedFeetechBus(list(range(1, 7))) as bus:
        for case, (checkpoint, needle) in cases.items():
            _refused(_record(bus, checkpoint, tmp_path / f"out-{case}"), f"{checkpoint / 'config.json'}: {needle}")
            assert not (tmp_path / f"out-{case}").exists()
        assert bus.packets == 0  # refused before the robot was connected


def test_policy_with_an_rskill_a_person_or_a_scene_is_one_line(project: Path, tmp_path: Path) -> None:
    checkpoint = _fake_checkpoint(tmp_path / "ckpt")
    args = ["record", "--hal", ROBOT, "--policy", str(checkpoint), "--out", str(tmp_path / "out")]
    _refused(run_inproc(*args, "--rskill", "sweep-so-arm"), "--policy, --rskill: give one")
    _refused(run_inproc(*args, "--teleop", "leader"), "--policy: not with --teleop leader")
    _refused(run_inproc(*args, "--scene", "tabletop_push"), "--policy: not with --hal --scene")
    no_policy = ["record", "--hal", ROBOT, "--rskill", "sweep-so-arm", "--device", "cpu", "--out", str(tmp_path / "o")]
    _refused(run_inproc(*no_policy), "--device: with --hal only for --policy")
    assert not (tmp_path / "out").exists() and not (tmp_path / "o").exists()
