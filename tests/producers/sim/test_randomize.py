"""Domain randomization of the tabletop scenes (`scene.params.randomize`): drawn from the episode seed, stored as
the episode's provenance, restored by replay, and invisible when off."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import mujoco
import numpy as np
import pyarrow.parquet as pq
import pytest

from openral_data.producers.sim.mujoco.scene import TabletopScene
from openral_data.runtime import registry
from tests.support.inproc import run_inproc
from tests.support.mujoco import FRONT, expert_rskill, shipped_scene
from tests.support.scenes import write_yaml

SMALL = FRONT.model_copy(update={"width": 64, "height": 64})
FULL: dict[str, Any] = {
    "light": {"intensity": [0.6, 1.4], "color": 0.1, "direction": 0.3},
    "colors": ["table", "goal"],
    "textures": ["table", "floor"],
    "cameras": {"pos": 0.03, "lookat": 0.02, "fovy": 3},
    "physics": {"objects": ["cube"], "mass": [0.7, 1.5], "friction": [0.8, 1.2], "size": [0.9, 1.1]},
    "distractors": {"count": [0, 3], "region": {"x": [0.4, 0.6], "y": [-0.2, 0.2]}},
}
# each declared dimension, alone, and a drawn key that must vary between seeds
DIMENSIONS: dict[str, tuple[dict[str, Any], str]] = {
    "light": ({"light": FULL["light"]}, "light.diffuse"),
    "colors": ({"colors": ["table"]}, "colors.table"),
    "textures": ({"textures": ["table"]}, "textures.table"),
    "cameras": ({"cameras": FULL["cameras"]}, "cameras.front"),
    "physics": ({"physics": {"objects": ["cube"], "size": [0.7, 1.3]}}, "physics.cube.size"),
    "distractors": ({"distractors": {**FULL["distractors"], "count": [1, 3]}}, "distractors.objects"),
}
SAID = "put the {cube.color} cube on the {goal.color} pad"  # the goal's colour varies: named per episode


def scene(randomize: dict[str, Any] | None) -> TabletopScene:
    params = {"randomize": randomize} if randomize is not None else None
    sim = shipped_scene("pick_place", [SMALL], params=params, instruction=SAID)
    return TabletopScene(sim, registry.ROBOTS["franka_panda"], expert_rskill("pick_place"), "pick_place")


def frame(s: TabletopScene) -> np.ndarray:
    mujoco.mj_forward(s.model, s.data)
    return s.rig.render(s.data)["front"]


def leaf(values: dict[str, Any], dotted: str) -> Any:
    for part in dotted.split("."):
        values = values[part]
    return values


def test_same_seed_same_frames_and_physics() -> None:
    a, b = scene(FULL), scene(FULL)
    try:
        obs_a, obs_b = a.reset(11), b.reset(11)
        assert a.initial_state() == b.initial_state()
        assert "randomization" in a.initial_state()
        rng = np.random.default_rng(0)
        for _ in range(8):
            action = rng.uniform(-1, 1, a.spec.action_dim).astype(np.float32)
            obs_a, obs_b = a.step(action).observation, b.step(action).observation
        assert np.array_equal(obs_a.images["front"], obs_b.images["front"])
        assert np.array_equal(obs_a.state, obs_b.state)
        assert np.array_equal(a.data.qpos, b.data.qpos)
    finally:
        a.close()
        b.close()


@pytest.mark.parametrize("dim", sorted(DIMENSIONS))
def test_each_dimension_varies_in_values_and_pixels(dim: str) -> None:
    block, key = DIMENSIONS[dim]
    s = scene(block)
    try:
        drawn = [s.randomizer.draw(seed) for seed in range(8)]
        assert len({json.dumps(leaf(v, key), sort_keys=True) for v in drawn}) > 1, drawn
        # the same placement with and without the episode's values: only the variation tells the pixels apart
        seed = next(k for k, v in enumerate(drawn) if leaf(v, key))
        s.reset(seed)
        varied = frame(s)
        s.randomizer.apply({})
        nominal = frame(s)
        assert np.count_nonzero((varied != nominal).any(axis=-1)) >= 8  # pixels the variation changed
    finally:
        s.close()


def test_values_reach_the_model() -> None:
    s = scene(FULL)
    try:
        s.reset(5)
        v, m = s.randomization, s.model
        assert np.allclose(m.light_diffuse[0], v["light"]["diffuse"])
        assert np.allclose(m.geom_rgba[m.geom("table").id], v["colors"]["table"])
        assert m.geom_matid[m.geom("floor").id] == m.material("rand/" + v["textures"]["floor"]).id
        assert m.cam_fovy[m.camera("front").id] == pytest.approx(v["cameras"]["front"]["fovy"])
        assert m.body_mass[m.body("cube").id] == pytest.approx(0.1 * v["physics"]["cube"]["mass"])
        size = m.geom_size[m.geom("cube").id][0]
        assert size == pytest.approx(0.02 * v["physics"]["cube"]["size"])
        # the cube rests on the table at its drawn size
        assert s.pos("cube")[2] == pytest.approx(s.table_height + size, abs=1e-6)
    finally:
        s.close()


def test_off_is_invisible_and_places_as_before() -> None:
    """A declared block that is off changes nothing an episode shows: parked distractors and unused textures are
    not seen, objects land where they land without the block."""
    plain, off = scene(None), scene({**FULL, "enabled": False})
    try:
        for seed in (0, 3):
            a, b = plain.reset(seed), off.reset(seed)
            assert np.array_equal(a.images["front"], b.images["front"])
            assert np.array_equal(plain.pos("cube"), off.pos("cube"))
            assert "randomization" not in off.initial_state()
            assert a.state.shape == b.state.shape
    finally:
        plain.close()
        off.close()


def randomized_yaml(tmp_path: Path, block: dict[str, Any], max_steps: int = 30) -> Path:
    sim = shipped_scene("pick_place", [SMALL], params={"randomize": block}, max_steps=max_steps, instruction=SAID)
    doc = sim.model_dump(mode="json", exclude_none=True)
    doc["scene"]["id"] = doc["task"]["scene_id"] = "pick_place_rand_test"
    return write_yaml(tmp_path / "scene.yaml", doc)


def episodes(out: Path) -> list[dict[str, Any]]:
    rows = [r for f in sorted((out / "meta" / "episodes").rglob("*.parquet")) for r in pq.read_table(f).to_pylist()]
    return [json.loads(r["openral.initial_state"]) for r in rows]


def test_record_replay_and_query(tmp_path: Path) -> None:
    yml = randomized_yaml(tmp_path, FULL)
    out = tmp_path / "ds"
    r = run_inproc("record", "--scene", str(yml), "--out", str(out), "--n-episodes", "2", "--json")
    assert r.returncode == 0, r.stdout + r.stderr
    states = episodes(out)
    assert all("randomization" in s for s in states)
    assert states[0]["randomization"] != states[1]["randomization"]
    r = run_inproc("replay", str(out), "--mode", "actions", "--json", "--out", str(tmp_path / "res"))
    assert r.returncode == 0, r.stdout + r.stderr
    summary = json.loads(r.stdout.strip().splitlines()[-1])
    assert summary["reproduced"] == 2 and summary["divergence_max"] == 0, summary
    sql = "SELECT episode_index, value FROM randomization WHERE key = 'physics.cube.mass' ORDER BY 1"
    r = run_inproc("stats", str(out), "--sql", sql, "--format", "json")
    assert r.returncode == 0, r.stdout + r.stderr
    masses = [states[k]["randomization"]["physics"]["cube"]["mass"] for k in range(2)]
    assert f"{masses[0]}" in r.stdout and f"{masses[1]}" in r.stdout


def test_randomize_flag(tmp_path: Path) -> None:
    yml = randomized_yaml(tmp_path, FULL, max_steps=5)
    out = tmp_path / "off"
    r = run_inproc("record", "--scene", str(yml), "--out", str(out), "--n-episodes", "1", "--randomize", "off")
    assert r.returncode == 0, r.stdout + r.stderr
    assert "randomization" not in episodes(out)[0]
    r = run_inproc("record", "--scene", "tabletop_push", "--out", str(tmp_path / "x"), "--randomize", "on")
    assert r.returncode == 2 and "scene.params.randomize" in r.stderr and len(r.stderr.strip().splitlines()) == 1
    assert not (tmp_path / "x").exists()
    r = run_inproc("record", "--scene", str(yml), "--out", str(tmp_path / "y"), "--randomize", "maybe")
    assert r.returncode == 2 and "--randomize" in r.stderr


@pytest.mark.parametrize(
    ("block", "field"),
    [
        ({"light": {"intensity": [0.5, 9.0]}}, "randomize.light"),
        ({"lights": {}}, "randomize.lights"),
        ({"colors": ["nope"]}, "randomize.colors[0]"),
        ({"cameras": {"names": ["wrist"]}}, "randomize.cameras.names[0]"),
        ({"physics": {"objects": ["goal"], "mass": [1, 2]}}, "randomize.physics.objects[0]"),
        ({"distractors": {"count": [2, 20]}}, "randomize.distractors"),
    ],
)
def test_bad_blocks_are_one_line(tmp_path: Path, block: dict[str, Any], field: str) -> None:
    yml = randomized_yaml(tmp_path, block, max_steps=5)
    out = tmp_path / "ds"
    r = run_inproc("record", "--scene", str(yml), "--out", str(out))
    assert r.returncode == 2, r.stdout + r.stderr
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and field in lines[0], r.stdout + r.stderr
    assert not out.exists()
