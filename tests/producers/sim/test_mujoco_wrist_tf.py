"""Per-frame /tf of a wrist camera's mount body in MCAP: with the camera's /tf_static extrinsics it places the
camera where MuJoCo has it at every frame (read back with the real mcap reader, compared with MuJoCo's
`cam_xpos` / `cam_xmat` in a second rollout of the same seed and actions)."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import numpy.typing as npt
import pytest

from openral_data.formats.lerobot_v3.reader import read_info
from tests.support.home import isolated_home
from tests.support.mcap import check_bag
from tests.support.mujoco import push_scene, record_push_variant

SEED, STEPS = 2, 6
WRIST = {"name": "wrist", "width": 32, "height": 32, "mount": "wrist"}
FRONT = {"name": "front", "width": 32, "height": 32, "pos": [1.2, 0.0, 1.3], "lookat": [0.42, 0.0, 0.85]}
TO_OPTICAL = np.diag([1.0, -1.0, -1.0])  # MuJoCo camera axes -> the optical frame's (x right, y down, z forward)


def _rot(q: list[float]) -> npt.NDArray[np.float64]:
    out = np.zeros(9)
    mujoco.mju_quat2Mat(out, np.asarray(q, dtype=np.float64))
    return out.reshape(3, 3)


@pytest.mark.slow
def test_wrist_camera_tf_composes_to_mujocos_camera_pose_at_every_frame(tmp_path: Path) -> None:
    with isolated_home(tmp_path / "home") as home:
        rec = record_push_variant(home, "tf_push", {"cameras": [FRONT, WRIST]}, SEED, STEPS, tmp_path / "out")
        env = push_scene(rec.scene_file)
        want: list[tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]] = []
        try:
            env.reset(SEED)
            cid = env.model.camera("wrist").id
            for action in rec.actions:
                want.append((env.data.cam_xpos[cid].copy(), env.data.cam_xmat[cid].reshape(3, 3) @ TO_OPTICAL))
                env.step(action)
        finally:
            env.close()
    ext = read_info(rec.out)["features"]["observation.images.wrist"]["info"]["extrinsics"]
    body = ext["parent_frame"]
    (bag,) = sorted((rec.out / "mcap").glob("episode_*"))
    msgs = check_bag(bag)  # rosbags, the mcap reader (CRCs, decoding) and `rerun mcap check`
    ((_, static),) = msgs["/tf_static"]
    mount = {t.child_frame_id: t for t in static.transforms}["wrist"]
    assert mount.header.frame_id == body
    r, t = mount.transform.rotation, mount.transform.translation
    rot_bc, pos_bc = _rot([r.w, r.x, r.y, r.z]), np.array([t.x, t.y, t.z])
    tfs = msgs["/tf"]
    assert len(tfs) == STEPS
    moved = 0.0
    for row, (_, msg) in enumerate(tfs):
        (tf,) = msg.transforms  # the front camera is fixed in the world: only the wrist's body moves
        assert tf.header.frame_id == "world" and tf.child_frame_id == body
        q, p = tf.transform.rotation, tf.transform.translation
        rot_wb, pos_wb = _rot([q.w, q.x, q.y, q.z]), np.array([p.x, p.y, p.z])
        pos, rot = pos_wb + rot_wb @ pos_bc, rot_wb @ rot_bc
        assert np.allclose(pos, want[row][0], atol=1e-9), (row, pos, want[row][0])
        assert np.allclose(rot, want[row][1], atol=1e-9), row
        moved = max(moved, float(np.linalg.norm(want[row][0] - want[0][0])))
    assert moved > 1e-3  # the arm moved: the per-frame poses are not one pose repeated
