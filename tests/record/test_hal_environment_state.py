"""A scene's `observation.environment_state` (its object poses, `observations.environment_state: true`) through the
HAL path (#51): `record --hal ROBOT --scene S` records the column as `record --scene S` does (same names, same
values at the same seed and actions), and the DAgger round (`record --policy CKPT --teleop expert`, the pipeline's
`dagger` step) gives it to a state-only checkpoint that was trained on it and records it, so `merge` with
`common: true` keeps it beside the demos'."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from openral_data.columns import INTERVENTION
from openral_data.pipeline.schema import DaggerStep, MergeStep, Seeds, Step
from openral_data.pipeline.steps import jobs_for
from openral_data.record.hal import HalRecordOptions, record_hal
from openral_data.record.options import RecordOptions
from openral_data.record.sim import record
from tests.support.checkpoint import make_act_checkpoint
from tests.support.hal import frames_table
from tests.support.home import REPO

SCENE = str(REPO / "pipelines/scenes/tabletop_push_state.yaml")  # cube and goal poses, a 32x32 camera
SEED, STEPS = 2, 30  # the expert's gripper reaches the cube at frame 22 of seed 2
ENV = "observation.environment_state"
POSE = ("x", "y", "z", "qw", "qx", "qy", "qz")


def _env(out: Path) -> tuple[list[str], np.ndarray]:
    """The recording's environment-state names (info.json) and its column, one row per frame."""
    names = json.loads((out / "meta/info.json").read_text())["features"][ENV]["names"]
    return names, np.asarray(frames_table(out)[ENV], dtype=np.float32)


@pytest.fixture(scope="module")
def demos(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """`record --scene`: one episode of the push expert on the scene, the reference of both tests."""
    out = tmp_path_factory.mktemp("envstate") / "demos"
    assert record(RecordOptions(scene=SCENE, n_episodes=1, seed=SEED, max_steps=STEPS, out=out, codec="h264")).frames
    return out


def test_the_hal_records_the_scenes_environment_state_as_record_scene_does(demos: Path, tmp_path: Path) -> None:
    out = tmp_path / "hal"
    opts = HalRecordOptions(robot="franka_panda", rskill="scripted-push", scene=SCENE, seed=SEED, max_steps=STEPS,
                            out=out, codec="h264")  # fmt: skip
    assert record_hal(opts).frames == STEPS
    names, env = _env(out)
    want_names, want = _env(demos)
    assert names == want_names == [f"{o}.{k}" for o in ("cube", "goal") for k in POSE]
    # the expert acted the same on the same observations: the same actions, hence the same poses, frame by frame
    np.testing.assert_array_equal(np.asarray(frames_table(out)["action"]), np.asarray(frames_table(demos)["action"]))
    assert env.shape == (STEPS, 14) and np.array_equal(env, want)
    assert (env[:, 7:] == env[0, 7:]).all()  # the goal stays where the seed drew it
    assert np.abs(env[:20, :3] - env[0, :3]).max() < 1e-3  # the cube rests until the gripper reaches it
    assert np.linalg.norm(env[-1, :2] - env[0, :2]) > 0.005  # then the arm pushes it


@pytest.mark.slow
def test_the_dagger_round_gives_a_state_only_checkpoint_its_environment_state(demos: Path, tmp_path: Path) -> None:
    """A state-only ACT (state + environment state, the camera dropped) made on the demos drives the DAgger round
    (threshold 0: the expert takes over after 2 ticks, for 3); the round records the column, and the merge of the
    demos and the round keeps it."""
    trained = tmp_path / "policy" / "item"
    make_act_checkpoint(demos, trained / "pretrained_model", drop=("observation.images.front",))
    paths = {"policy": [("item", trained)], "demos": [("demos", demos)]}
    rule = {"threshold": 0.0, "patience": 2, "hold": 3}
    step = Step(id="corrected", dagger=DaggerStep(policy="policy", scene=SCENE, seeds=Seeds(start=SEED, count=1),
                                                  max_steps=8, **rule))  # fmt: skip
    ((name, run),) = jobs_for(step, paths.__getitem__)
    round_out = tmp_path / name
    assert run(round_out)["frames"] == 8
    assert frames_table(round_out)[INTERVENTION] == [False, False, True, True, True, False, False, True]
    names, env = _env(round_out)
    demo_names, demo_env = _env(demos)
    assert names == demo_names and env.shape == (8, 14)
    assert np.array_equal(env[0], demo_env[0])  # the same seed: the same start
    assert (env[:, 7:] == demo_env[0, 7:]).all()

    paths["corrected"] = [(name, round_out)]
    merged = tmp_path / "all"
    merge = Step(id="all", merge=MergeStep(inputs=["demos", "corrected"], order="seed", common=True))
    ((_, run_merge),) = jobs_for(merge, paths.__getitem__)
    assert run_merge(merged)["frames"] == STEPS + 8
    merged_names, merged_env = _env(merged)
    assert merged_names == names and np.array_equal(merged_env, np.concatenate([demo_env, env]))
