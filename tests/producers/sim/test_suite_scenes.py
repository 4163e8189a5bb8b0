"""Benchmark-suite scenes part B (gym-pusht, gym-aloha, LIBERO) as a whole: shipped YAMLs, fixed robots, the
LIBERO extra's conflicts and its refusal outside its own environment."""

from __future__ import annotations

import importlib.util
import subprocess
from pathlib import Path

import pytest

# ConfigError raises are matched by message on purpose: the file and field it names are the point
from openral_data.errors import ConfigError
from openral_data.record.options import RecordOptions
from openral_data.record.sim import record
from openral_data.runtime import registry
from openral_data.schemas.scene import BenchmarkScene, load_recordable_scene
from tests.support.cli import run_cli
from tests.support.home import REPO
from tests.support.uv import uv

SIM = ["pusht", "aloha_transfer_cube", "aloha_insertion", "libero_spatial", "libero_object", "libero_goal", "libero_10"]
RSKILL = {"gym_pusht": "random-pusht", "gym_aloha": "random-aloha", "libero": "random-libero"}


@pytest.mark.parametrize("scene_id", SIM)
def test_shipped_scenes_are_fixed_robot_with_a_benchmark_twin(scene_id: str) -> None:
    sim = load_recordable_scene(registry.resolve_scene_path(scene_id))
    bench = load_recordable_scene(registry.resolve_scene_path(f"{scene_id}_bench"))
    assert isinstance(bench, BenchmarkScene) and not isinstance(sim, BenchmarkScene)
    for scene in (sim, bench):
        assert scene.scene.type in RSKILL and scene.scene.fixed_robot and scene.scene.robot in registry.ROBOTS
        assert scene.scene.type in registry.SCENES
    assert bench.scene.params == sim.scene.params and bench.task.instruction == sim.task.instruction
    assert "random policy" in bench.metadata.honest_scope and bench.n_episodes == 50
    rskill = registry.resolve_rskill(RSKILL[sim.scene.type])[0]
    robot = registry.ROBOTS[sim.scene.robot or ""]
    assert set(rskill.embodiment_tags) & set(robot.embodiment_tags)
    assert rskill.state_contract.names == (robot.observation.state.names or [])
    assert rskill.action_contract.names == (robot.action.names or [])


def test_libero_pro_benchmark_scenes_compare_with_their_base_suite() -> None:
    """Each of the 16 LIBERO-PRO suites has a benchmark scene on its task 0 that differs from its base suite's only
    in the suite (and, where the suite changes the language, the instruction): same robot, cameras, seeds, episode
    count and step limit, so their success rates compare; its metadata names LIBERO-PRO and the perturbation."""
    from openral_data.producers.sim.libero.pro import PERTURBATIONS, PRO_SUITES, split

    for suite in PRO_SUITES:
        bench = load_recordable_scene(registry.resolve_scene_path(f"{suite}_bench"))
        base_name, suffix = split(suite)
        assert suffix is not None
        base = load_recordable_scene(registry.resolve_scene_path(f"{base_name}_bench"))
        assert isinstance(bench, BenchmarkScene) and isinstance(base, BenchmarkScene)
        assert bench.scene.params == {**base.scene.params, "suite": suite}
        assert (bench.scene.robot, bench.scene.cameras, bench.seed, bench.n_episodes, bench.task.max_steps) == (
            base.scene.robot,
            base.scene.cameras,
            base.seed,
            base.n_episodes,
            base.task.max_steps,
        )
        same_words = bench.task.instruction == base.task.instruction
        assert same_words == (suffix in ("object", "swap")), suite
        assert "LIBERO-PRO" in bench.metadata.paper and PERTURBATIONS[suffix] in bench.metadata.paper
        assert "random policy" in bench.metadata.honest_scope and f"{base_name}_bench" in bench.metadata.honest_scope


def test_fixed_robot_is_refused_before_anything_is_written(project: Path, tmp_path: Path) -> None:
    for scene_id in ("aloha_insertion", "libero_goal"):
        with pytest.raises(ConfigError, match=r"scene\.fixed_robot"):
            record(RecordOptions(scene=scene_id, rskill="random-aloha", robot="franka_panda", out=tmp_path / "x"))
    assert not (tmp_path / "x").exists()


@pytest.mark.skipif(importlib.util.find_spec("libero") is not None, reason="LIBERO is installed in this environment")
def test_libero_outside_its_environment_is_one_line_naming_the_extra(project: Path, tmp_path: Path) -> None:
    proc = run_cli("record", "--scene", "libero_spatial", "--rskill", "random-libero", "--out", str(tmp_path / "o"))
    assert proc.returncode == 2 and "Traceback" not in proc.stderr
    line = proc.stderr.strip().splitlines()[-1]
    assert "scene.type: libero needs the 'libero' extra" in line and "setup_libero.sh" in line
    assert not (tmp_path / "o").exists()


def test_resolver_refuses_libero_next_to_robosuite_or_metaworld() -> None:
    for other in ("robosuite", "metaworld"):
        proc = subprocess.run(
            [uv(), "sync", "--frozen", "--dry-run", "--extra", "libero", "--extra", other],
            cwd=REPO,
            capture_output=True,
            text=True,
            timeout=120,
            check=False,
        )
        message = " ".join(proc.stderr.split())  # uv wraps long lines
        assert (
            proc.returncode != 0
            and f"Extras `libero` and `{other}` are incompatible with the declared conflicts" in message
        )


@pytest.mark.parametrize(
    "scene_id",
    [
        "maniskill_pick_cube",
        "maniskill_push_cube",
        "maniskill_stack_cube",
        "robosuite_g1_lift",
        "robosuite_h1_lift",
        "robosuite_gr1_lift",
        "robosuite_aloha_lift",
    ],
)
def test_new_suites_have_a_benchmark_twin_of_the_same_scene(scene_id: str) -> None:
    """ManiSkill3's and the humanoids' benchmark scenes: the sim scene's robot, cameras, parameters and instruction,
    50 fixed seeds from 1000, and a scope that says what the default rSkill is (an expert or a random floor)."""
    sim = load_recordable_scene(registry.resolve_scene_path(scene_id))
    bench = load_recordable_scene(registry.resolve_scene_path(f"{scene_id}_bench"))
    assert isinstance(bench, BenchmarkScene) and not isinstance(sim, BenchmarkScene)
    assert bench.scene.type == sim.scene.type and bench.scene.type in registry.SCENES
    assert (bench.scene.robot, bench.scene.default_rskill) == (sim.scene.robot, sim.scene.default_rskill)
    assert bench.scene.cameras == sim.scene.cameras and bench.scene.params == sim.scene.params
    assert bench.task.instruction == sim.task.instruction and bench.task.max_steps == sim.task.max_steps
    assert (bench.seed, bench.n_episodes) == (1000, 50)
    scope = bench.metadata.honest_scope
    assert ("random policy" in scope) == (sim.scene.type == "robosuite") and "success is" in scope
