"""robosuite's humanoids and bimanual arms (robosuite-models 1.0.0: G1, H1, ALOHA; robosuite's GR1) in Lift under
the BASIC composite controller: named state and action that mean what they say, recorded, loaded frame-exact by
lerobot, restored and replayed bit for bit."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest

from openral_data.errors import CompatibilityError
from openral_data.record.options import RecordOptions
from openral_data.record.sim import record
from openral_data.runtime import registry
from tests.support.suites import build, lerobot_table, project_point, rollout, shipped, small_scene_file

pytest.importorskip("robosuite")
pytest.importorskip("robosuite_models")

SIZE = 40
STEPS = 4


def _red(img: np.ndarray) -> np.ndarray:
    i = img.astype(int)
    return np.asarray(i[..., 0] - np.maximum(i[..., 1], i[..., 2]) > 40)


def _mjcf_joint(name: str) -> str:
    """The MJCF joint a state name stands for: `right_hand.x` -> `gripper0_right_x`, a body joint -> `robot0_x`."""
    hand, _, joint = name.partition("_hand.")
    return f"gripper0_{hand}_{joint}" if joint else f"robot0_{name}"


@pytest.mark.slow
@pytest.mark.parametrize(
    ("short", "robot_id", "arm_tracks"),
    [
        ("g1", "unitree_g1", True),
        ("h1", "unitree_h1", False),
        ("gr1", "fourier_gr1", True),
        ("aloha", "robosuite_aloha", True),
    ],
)
def test_robot_records_its_named_body_loads_frame_exact_and_replays(
    short: str, robot_id: str, arm_tracks: bool, project: Path, tmp_path: Path
) -> None:
    scene_id, rskill_id = f"robosuite_{short}_lift", f"robosuite-{short}-random"
    robot = registry.ROBOTS[robot_id]
    out = tmp_path / short
    # no rskill: the scene's default (random arms and hands, torso/legs held)
    summary = record(
        RecordOptions(
            scene=str(small_scene_file(project, scene_id, size=SIZE)), n_episodes=1, seed=3, max_steps=STEPS, out=out
        )
    )
    assert summary.frames == STEPS
    ds, cols = lerobot_table(out)
    assert ds.meta.robot_type == robot_id and len(ds) == STEPS
    state_names, action_names = robot.observation.state.names or [], robot.action.names or []
    assert ds.meta.features["observation.state"]["names"] == state_names
    assert ds.meta.features["action"]["names"] == action_names

    env = build(shipped(scene_id, cameras=[("agentview", SIZE, SIZE)]), rskill_id)
    try:
        model = env.model  # type: ignore[attr-defined]
        # every state entry is one joint of the MJCF: body joints, then each hand's fingers
        qpos = [model.jnt_qposadr[model.joint(_mjcf_joint(n)).id] for n in state_names]
        # restored from the recorded initial state, the recorded actions give the recorded states bit for bit
        initial = json.loads(ds.meta.episodes["openral.initial_state"][0])
        obs = env.reset_to(initial)
        assert np.array_equal(obs.state, env.data.qpos[qpos].astype(np.float32))  # type: ignore[attr-defined]
        run = rollout(env, None, obs, STEPS, actions=list(cols["action"]))
        assert np.array_equal(cols["observation.state"], run["states"][:STEPS])
        assert list(cols["next.success"]) == run["successes"] == [False] * STEPS  # robosuite's _check_success

        # upright: the red cube is where the geometry puts it; the wall is at the top, the table at the bottom
        img = obs.images["agentview"]
        row, col = project_point(model, env.data, "agentview", obs.privileged["cube_pos"], SIZE, SIZE)  # type: ignore[attr-defined]
        assert _red(img)[row - 2 : row + 3, col - 2 : col + 3].any(), (row, col)
        table = img.min(axis=2) > 200
        assert table[-2:].mean() > 0.8 and table[:2].mean() < 0.2

        # a zero action holds torso, head and arms (the hands go to mid-travel; the legs hang from the fixed base
        # and sag a little under their joint-position servos)
        obs = env.reset(3)
        body = [k for k, n in enumerate(state_names) if "_hand." not in n and "_leg_" not in n]
        zero = np.zeros(len(action_names), dtype=np.float32)
        held = rollout(env, None, obs, 3, actions=[zero] * 3)["states"]
        assert np.abs(held[-1][body] - held[0][body]).max() < 0.05
        # a joint-position part moves its own joint: `torso.<joint>` +1 turns that joint most
        moved = next((n for n in action_names if n.startswith("torso.")), None)
        if moved is not None:
            turn = zero.copy()
            turn[action_names.index(moved)] = 1.0
            turned = rollout(env, None, env.reset(3), 2, actions=[turn] * 2)["states"]
            change = np.abs(turned[-1][body] - turned[0][body])
            assert state_names[body[int(change.argmax())]] == moved.split(".", 1)[1] and change.max() > 0.01
        if arm_tracks:  # `right_arm.dz` raises the right hand only (H1's 4-joint arms do not track a 6-D delta)
            obs = env.reset(3)
            up = zero.copy()
            up[action_names.index("right_arm.dz")] = 1.0
            before = {arm: obs.privileged[f"{arm}_eef_pos"].copy() for arm in ("right", "left")}  # type: ignore[literal-required]
            for _ in range(4):
                obs = env.step(up).observation
            assert obs.privileged["right_eef_pos"][2] - before["right"][2] > 0.015  # type: ignore[typeddict-item]
            assert np.linalg.norm(obs.privileged["left_eef_pos"] - before["left"]) < 0.02  # type: ignore[typeddict-item]
    finally:
        env.close()

    # an rSkill naming the body otherwise is refused at the contract
    rskill = registry.resolve_rskill(rskill_id)[0]
    swapped = [state_names[1], state_names[0], *state_names[2:]]
    bad = rskill.model_copy(update={"state_contract": rskill.state_contract.model_copy(update={"names": swapped})})
    with pytest.raises(
        CompatibilityError, match=re.escape(f"state_contract.names: entry 0 is {swapped[0]!r}, robot {robot_id!r} has")
    ):
        registry.SCENES["robosuite"](shipped(scene_id, cameras=[]), robot, bad, "x.yaml")
