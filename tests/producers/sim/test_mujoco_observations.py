"""Observations of the MuJoCo tabletop scenes beyond RGB: depth cameras, camera geometry, object poses as
`observation.environment_state` and the gripper width, recorded to LeRobot v3 and MCAP and read back with the
real readers (lerobot 0.6.1, rosbags, mcap). The reference is a second rollout of the same scene: reset with
the recorded seed, stepped with the recorded actions (MuJoCo is deterministic), rendered by the same rig."""

from __future__ import annotations

import json
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import mujoco
import numpy as np
import numpy.typing as npt
import pytest

from openral_data.errors import ConfigError
from openral_data.formats.lerobot_v3.depth import DepthSettings
from openral_data.producers.sim.mujoco.camera_geometry import project
from openral_data.schemas.rskill import Contract
from openral_data.schemas.scene import load_recordable_scene
from tests.support.cli import run_cli
from tests.support.home import isolated_home
from tests.support.mcap import check_bag
from tests.support.mujoco import expert_rskill, make_scene, push_scene, record_push_variant, red_mask
from tests.support.rrd import verify
from tests.support.scenes import mock_scene, write_yaml

SEED, STEPS, SIZE = 3, 12, 128
FRONT_POS = [1.2, 0.0, 1.3]
FRONT = {"name": "front", "width": SIZE, "height": SIZE, "pos": FRONT_POS, "lookat": [0.42, 0.0, 0.85]}
WRIST = {"name": "wrist", "width": 64, "height": 64, "mount": "wrist"}
POSE = ("x", "y", "z", "qw", "qx", "qy", "qz")


@dataclass
class Recorded:
    out: Path
    scene_file: Path
    info: dict[str, Any]
    depth: list[dict[str, npt.NDArray[np.float32]]]  # per row: the reference render of each depth camera
    rgb: list[dict[str, npt.NDArray[np.uint8]]]
    poses: list[dict[str, npt.NDArray[np.float64]]]  # per row: privileged["object_poses"] and ["fixed_poses"]


def _rollout(scene_file: Path, actions: npt.NDArray[np.float32]) -> Recorded:
    env = push_scene(scene_file)
    depth, rgb, poses = [], [], []
    try:
        obs = env.reset(SEED)
        for action in actions:
            depth.append({k: v for k, v in obs.images.items() if v.ndim == 2})
            rgb.append({k: v for k, v in obs.images.items() if v.ndim == 3})
            both = {**obs.privileged["fixed_poses"], **obs.privileged["object_poses"]}
            poses.append({k: np.asarray(v) for k, v in both.items()})
            obs = env.step(action).observation
    finally:
        env.close()
    return Recorded(Path(), scene_file, {}, depth, rgb, poses)


@pytest.fixture(scope="module")
def recorded(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Recorded]:
    """One episode of the push expert with a depth front camera (128²), a depth wrist camera and object poses,
    recorded to LeRobot v3 and MCAP; and the reference rollout of the same seed and actions."""
    base = tmp_path_factory.mktemp("observations")
    with isolated_home(base / "home") as home:
        cameras = [{**FRONT, "depth": True}, {**WRIST, "depth": True}]
        scene = {"cameras": cameras, "observations": {"environment_state": True, "environment_goal": True}}
        rec = record_push_variant(home, "depth_push", scene, SEED, STEPS, base / "out")
        ref = _rollout(rec.scene_file, rec.actions)
        ref.out, ref.info = rec.out, json.loads((rec.out / "meta/info.json").read_text())
        yield ref


def _one_step_mm(settings: DepthSettings, metres: npt.NDArray[np.float32]) -> npt.NDArray[np.float64]:
    """The spacing (mm) between the 12-bit code of each depth and the next one: one quantization step."""
    codes = settings.quantize(metres, "m").astype(np.int64)
    up = settings.dequantize(np.minimum(codes + 1, 4095)).astype(np.float64)
    down = settings.dequantize(np.maximum(codes - 1, 0)).astype(np.float64)
    return np.maximum(up - settings.dequantize(codes), settings.dequantize(codes) - down) * 1000.0


@pytest.mark.slow
def test_depth_cameras_decode_in_lerobot_within_one_quantization_step_of_the_render(recorded: Recorded) -> None:
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    ds = LeRobotDataset("local/depth", root=recorded.out, video_backend="pyav")
    assert sorted(ds.meta.depth_keys) == ["observation.images.front_depth", "observation.images.wrist_depth"]
    settings = DepthSettings()
    for key in ds.meta.depth_keys:
        info = ds.meta.features[key]["info"]
        assert info["is_depth_map"] is True and info["depth_unit"] == "m"
    assert len(ds) == STEPS == len(recorded.depth)
    for row in range(STEPS):
        item = ds[row]
        for cam in ("front_depth", "wrist_depth"):
            want = recorded.depth[row][cam]
            assert want.dtype == np.float32 and want.shape == (item[f"observation.images.{cam}"].shape[1:])
            got_mm = item[f"observation.images.{cam}"].numpy()[0].astype(np.float64)  # lerobot: millimetres
            clipped = np.clip(want, settings.depth_min, settings.depth_max)
            err = np.abs(got_mm - clipped.astype(np.float64) * 1000.0)
            assert (err <= _one_step_mm(settings, clipped) + 0.5).all(), (cam, row, float(err.max()))
            assert float(want.min()) < 2.5  # the table and the cube are in view, not only the far plane


@pytest.mark.slow
def test_environment_state_is_the_simulators_object_poses_at_every_row(recorded: Recorded) -> None:
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    feature = recorded.info["features"]["observation.environment_state"]
    # the cube's pose, then (environment_goal) the goal's, drawn from the seed: what a state-only policy needs
    assert feature["names"] == [f"{o}.{k}" for o in ("cube", "goal") for k in POSE] and feature["shape"] == [14]
    table = LeRobotDataset("local/depth", root=recorded.out, video_backend="pyav").hf_dataset.with_format("numpy")
    env = np.stack(table["observation.environment_state"])
    want = np.stack([np.concatenate([p["cube"], p["goal"]]).astype(np.float32) for p in recorded.poses])
    assert want.shape == (STEPS, 14) and np.array_equal(env.astype(np.float32), want)
    assert (env[:, 7:] == env[0, 7:]).all() and np.linalg.norm(env[0, 7:9] - env[0, :2]) > 0.1  # fixed, apart


@pytest.mark.slow
def test_intrinsics_and_extrinsics_reproject_the_cube_centre_onto_the_red_pixels(recorded: Recorded) -> None:
    feats = recorded.info["features"]
    for cam in ("front", "front_depth"):
        info = feats[f"observation.images.{cam}"]["info"]
        k = info["intrinsics"]
        f = (SIZE / 2) / np.tan(np.deg2rad(45.0) / 2)
        assert (k["fx"], k["fy"], k["cx"], k["cy"]) == pytest.approx((f, f, (SIZE - 1) / 2, (SIZE - 1) / 2))
        assert info["camera_info"]["k"] == pytest.approx([f, 0, (SIZE - 1) / 2, 0, f, (SIZE - 1) / 2, 0, 0, 1])
        assert info["extrinsics"]["parent_frame"] == "world" and info["extrinsics"]["convention"] == "opencv_optical"
        assert info["extrinsics"]["position"] == pytest.approx(FRONT_POS)
    wrist = feats["observation.images.wrist"]["info"]["extrinsics"]
    assert wrist["parent_frame"].startswith("robot/")  # moves with the arm: its pose is in the body it is on
    info = feats["observation.images.front"]["info"]
    cube_size = 0.04
    for row in (0, STEPS - 1):
        centre = recorded.poses[row]["cube"][:3]
        u, v = project(info, centre)
        mask = red_mask(recorded.rgb[row]["front"])
        assert mask.sum() >= 10
        rows, cols = np.nonzero(mask)
        assert abs(float(cols.mean()) - u) < 2.0 and abs(float(rows.mean()) - v) < 2.0, (row, u, v)
        # the depth camera agrees: at the cube's pixel, depth is the centre's optical z less about half the cube
        rot = np.zeros(9)
        mujoco.mju_quat2Mat(rot, np.asarray(info["extrinsics"]["quaternion"], dtype=np.float64))
        z = (rot.reshape(3, 3).T @ (centre - np.asarray(info["extrinsics"]["position"])))[2]
        depth = float(recorded.depth[row]["front_depth"][round(v), round(u)])
        assert z - cube_size <= depth <= z, (depth, z)


@pytest.mark.slow
def test_mcap_has_32fc1_depth_camera_info_and_static_tf(recorded: Recorded) -> None:
    (bag,) = sorted((recorded.out / "mcap").glob("episode_*"))
    msgs = check_bag(bag)  # rosbags, the mcap reader (CRCs, decoding) and `rerun mcap check`
    feats = recorded.info["features"]
    for cam in ("front_depth", "wrist_depth"):
        images = msgs[f"/camera/{cam}/depth/image_raw"]
        assert len(images) == STEPS
        for row, (_, msg) in enumerate(images):
            assert msg.encoding == "32FC1" and msg.step == 4 * msg.width
            got = np.frombuffer(bytes(msg.data), dtype="<f4").reshape(msg.height, msg.width)
            assert np.array_equal(got, recorded.depth[row][cam])
    for cam in ("front", "front_depth", "wrist", "wrist_depth"):
        ((_, info),) = msgs[f"/camera/{cam}/camera_info"]
        want = feats[f"observation.images.{cam}"]["info"]["camera_info"]
        assert info.header.frame_id == cam and (info.width, info.height) == (want["width"], want["height"])
        assert np.allclose(info.k, want["k"]) and np.allclose(info.p, want["p"])
    ((_, tf),) = msgs["/tf_static"]
    frames = {t.child_frame_id: t for t in tf.transforms}
    assert set(frames) == {"front", "front_depth", "wrist", "wrist_depth"}
    front = frames["front"]
    ext = feats["observation.images.front"]["info"]["extrinsics"]
    assert front.header.frame_id == "world"
    r = front.transform.rotation
    assert np.allclose([r.w, r.x, r.y, r.z], ext["quaternion"])
    t = front.transform.translation
    assert np.allclose([t.x, t.y, t.z], FRONT_POS)
    assert frames["wrist"].header.frame_id == feats["observation.images.wrist"]["info"]["extrinsics"]["parent_frame"]


def test_gripper_width_state_is_the_finger_gap_in_metres() -> None:
    rskill = expert_rskill("push")
    names = ["x", "y", "z", "qw", "qx", "qy", "qz", "gripper_width"]
    state = Contract(dim=8, names=names, representation="eef_pose_gripper_width")
    scene = make_scene("push", rskill=rskill.model_copy(update={"state_contract": state}))
    try:
        obs = scene.reset(0)
        assert obs.state[7] == pytest.approx(0.08, abs=0.003)  # the panda hand opens 2 x 40 mm
        close = np.zeros(scene.spec.action_dim or 0, dtype=np.float32)
        close[-1] = 1.0
        for _ in range(20):
            obs = scene.step(close).observation
        assert obs.state[7] < 0.005
        pos, quat = scene.arm.ee_pose(scene.data)
        assert np.allclose(obs.state[:3], pos, atol=1e-6)
        assert abs(float(np.dot(obs.state[3:7], quat))) == pytest.approx(1.0, abs=1e-6)  # the same rotation (q or -q)
    finally:
        scene.close()


def test_depth_and_environment_state_are_refused_where_a_scene_cannot_give_them(project: Path) -> None:
    # a depth stream's name may not be another camera's
    data = mock_scene(cameras=[("front", 32, 32), ("front_depth", 32, 32)])
    data["scene"]["cameras"][0]["depth"] = True
    with pytest.raises(ConfigError, match=r"duplicate camera names .*\['front_depth'\]"):
        load_recordable_scene(write_yaml(project / "dup.yaml", data))
    # the mock scene renders no depth and reports no object poses: one line, exit 2, the field named
    data = mock_scene(cameras=[("front", 32, 32)])
    data["scene"]["cameras"][0]["depth"] = True
    path = write_yaml(project / "scenes/sim/depth_mock.yaml", data)
    res = run_cli("record", "--scene", str(path), "--rskill", "zero-mock", "--out", str(project / "d1"))
    assert res.returncode == 2
    assert res.stderr.splitlines()[0] == f"error: {path}: scene.cameras[0].depth: this scene type renders no depth"
    data = mock_scene(cameras=[("front", 32, 32)])
    data["scene"]["observations"] = {"environment_state": True}
    path = write_yaml(project / "scenes/sim/env_mock.yaml", data)
    res = run_cli("record", "--scene", str(path), "--rskill", "zero-mock", "--out", str(project / "d2"))
    assert res.returncode == 2
    assert res.stderr.splitlines()[0] == (
        f"error: {path}: scene.observations.environment_state: scene type 'mock' reports no object poses"
    )
    assert not (project / "d1").exists() and not (project / "d2").exists()


@pytest.mark.slow
def test_doctor_stats_and_replay_handle_depth_and_environment_state(recorded: Recorded, tmp_path: Path) -> None:
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    # the decoded depth agrees with the stored statistics (the sky, +inf in the render, is left out of both)
    assert float(recorded.depth[0]["front_depth"].max()) == np.inf
    doctor = run_cli("doctor", "--deep", str(recorded.out))
    assert doctor.returncode == 0 and doctor.stdout.strip().endswith("healthy"), doctor.stdout + doctor.stderr
    stats = run_cli("stats", str(recorded.out), "--format", "json")
    assert stats.returncode == 0, stats.stderr
    assert "cube.qz" in stats.stdout
    view = run_cli("view", str(recorded.out), "--save", str(tmp_path / "ep.rrd"))
    assert view.returncode == 0, view.stderr
    verify(tmp_path / "ep.rrd")
    # actions replay reproduces the episode; re-recorded, it has the same depth cameras and object poses
    replay = run_cli(
        "replay", str(recorded.out), "--out", str(tmp_path / "r"), "--record", str(tmp_path / "again"), "--json"
    )
    assert replay.returncode == 0, replay.stderr
    doc = json.loads(replay.stdout)
    assert doc["reproduced"] == 1 and doc["divergence_max"] == 0.0
    again = LeRobotDataset("local/again", root=tmp_path / "again", video_backend="pyav")
    assert sorted(again.meta.depth_keys) == ["observation.images.front_depth", "observation.images.wrist_depth"]
    table = again.hf_dataset.with_format("numpy")
    want = np.stack([np.concatenate([p["cube"], p["goal"]]).astype(np.float32) for p in recorded.poses])
    assert np.array_equal(np.stack(table["observation.environment_state"]).astype(np.float32), want)
