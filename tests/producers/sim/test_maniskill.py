"""ManiSkill3 adapter (runs in .venv-maniskill: `bash scripts/setup_maniskill.sh`; `.ci/run` runs this file there).

The motion-planning expert records PickCube with ManiSkill's own success; lerobot (in .venv: the ManiSkill
environment has none) loads the episode frame-exact; the camera is upright and its depth is the scene's; replay
of the actions reproduces the episode exactly (CPU simulation is deterministic).
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow.parquet as pq
import pytest

pytest.importorskip(
    "mani_skill", reason="ManiSkill3 has its own environment: bash scripts/setup_maniskill.sh, then .venv-maniskill"
)

from openral_data.errors import CompatibilityError, ConfigError
from openral_data.producers.sim.maniskill.tasks import suite_tasks
from openral_data.record.options import RecordOptions
from openral_data.record.sim import record
from openral_data.replay import ReplayOptions, replay
from tests.support.exported import read_elsewhere
from tests.support.home import REPO
from tests.support.suites import build, shipped

LEROBOT_PYTHON = REPO / ".venv/bin/python"
SIZE = 64


def _cube_pixel_and_depth(seed: int) -> tuple[tuple[float, float], float]:
    """Where PickCube's cube centre is in an upright base_camera image (row, col) after reset(seed), and its
    distance along the camera's axis (mm), from the camera's own intrinsics/extrinsics (OpenCV convention)."""
    env = build(shipped("maniskill_pick_cube", cameras=[("base_camera", SIZE, SIZE)]), "maniskill-expert")
    try:
        env.reset(seed)
        unwrapped = env.env.unwrapped  # type: ignore[attr-defined]
        params = unwrapped._sensors["base_camera"].get_params()
        k = params["intrinsic_cv"][0].numpy()
        ext = params["extrinsic_cv"][0].numpy()
        centre = unwrapped.cube.pose.p[0].numpy()
    finally:
        env.close()
    cam = ext[:3, :3] @ centre + ext[:3, 3]
    u, v, _ = k @ (cam / cam[2])
    return (float(v), float(u)), float(cam[2] * 1000)


def test_tasks_and_contract_checks() -> None:
    """`list tasks` offers ManiSkill's offline tasks; a wrong instruction or an rSkill of another shape is refused."""
    scene = shipped("maniskill_pick_cube", cameras=[])
    ids = [t.id for t in suite_tasks(scene, "s")]
    assert ids[0] == "PickCube-v1" and {"PushCube-v1", "StackCube-v1", "PegInsertionSide-v1"} <= set(ids)
    wrong = scene.model_copy(update={"task": scene.task.model_copy(update={"instruction": "wave"})})
    with pytest.raises(ConfigError, match=r"task\.instruction"):
        build(wrong, "maniskill-expert")
    with pytest.raises(CompatibilityError, match="pd_joint_pos"):
        build(scene, "random-libero")


@pytest.mark.slow
def test_expert_records_pickcube_lerobot_loads_it_upright_and_replay_reproduces(project: Path, tmp_path: Path) -> None:
    seed = 3
    data = json.loads(shipped("maniskill_pick_cube").model_dump_json())
    data["scene"]["cameras"] = [{"name": "base_camera", "width": SIZE, "height": SIZE, "depth": True}]
    path = project / "scenes/sim/maniskill_small.yaml"
    path.write_text(json.dumps(data))
    out = tmp_path / "pick"
    summary = record(RecordOptions(scene=str(path), n_episodes=1, max_steps=100, seed=seed, out=out))
    frames = summary.frames
    assert 20 < frames < 100  # the expert's plan ends on ManiSkill's success, before the step limit

    table = pq.read_table(out / "data").to_pydict()
    success = np.asarray(table["next.success"])
    assert success[-1] and not success[:-1].any()  # ManiSkill's `success` ends the episode, and only there
    info = json.loads((out / "meta/info.json").read_text())
    assert info["robot_type"] == "maniskill_panda" and info["fps"] == 20

    if LEROBOT_PYTHON.is_file() or os.environ.get("CI"):
        npz = tmp_path / "lerobot.npz"
        read_elsewhere(LEROBOT_PYTHON, "readers/lerobot_frames.py", [str(out), str(npz)])
        got = np.load(npz)
        assert np.array_equal(got["state"], np.stack(table["observation.state"]).astype(np.float32))
        assert np.array_equal(got["action"], np.stack(table["action"]).astype(np.float32))
        assert got["frame"].tolist() == list(range(frames)) and got["success"].tolist() == success.tolist()
        assert set(got["task"]) == {"pick up the red cube and move it to the green goal"}
        (row, col), depth_mm = _cube_pixel_and_depth(seed)
        r, c = round(row), round(col)
        # upright and not mirrored: the reddest pixel (least green for its red) is the red cube, where the camera
        # model projects it; the wooden table is below the grey backdrop
        rgb = got["images|observation.images.base_camera"][0].astype(np.float64)
        greenness = np.where(rgb[..., 0] > 60, rgb[..., 1] / np.maximum(rgb[..., 0], 1), np.inf)
        reddest = np.unravel_index(np.argmin(greenness), greenness.shape)
        assert abs(reddest[0] - row) <= 2 and abs(reddest[1] - col) <= 2
        assert (rgb[-8:, :, 0] - rgb[-8:, :, 2]).mean() > 60 > abs(rgb[:4, :, 0] - rgb[:4, :, 2]).mean()
        # depth (millimetres, lossless): the cube's near face stands out of the table there, the table comes
        # nearer towards the image's bottom
        depth = got["depth|observation.images.base_camera_depth"][0]
        assert depth_mm - 45 < depth[r, c] < depth_mm
        assert depth[r, c] < min(depth[r, c - 6], depth[r, c + 6]) - 20
        assert depth[-1].mean() < depth[r + 6].mean()

    result = replay(ReplayOptions(out, out=tmp_path / "replay"))
    s: dict[str, Any] = dict(result.summary)
    assert s["reproduced"] == 1 and s["success_agree"] == 1 and s["success_replayed"] == 1
    assert s["divergence_max"] == 0.0
