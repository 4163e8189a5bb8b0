"""Tabletop scenes as data: YAML-declared objects (primitives, a mesh, a drawer), seeded clutter, the declarative
success criteria on real MuJoCo states, privileged object ground truth and its restore."""

from __future__ import annotations

import json
import re
from typing import Any

import mujoco
import numpy as np
import pytest
from pydantic import TypeAdapter

# ConfigError raises are matched by message on purpose: the file and field it names are the point
from openral_data.errors import ConfigError
from openral_data.producers.sim.mujoco.scene import TabletopScene
from openral_data.producers.sim.mujoco.success import holds
from openral_data.schemas.tabletop import Criterion
from tests.support.cli import run_cli
from tests.support.mujoco import layout_scene, shipped_scene
from tests.support.scenes import write_yaml

CRITERION: TypeAdapter[Criterion] = TypeAdapter(Criterion)
ZERO = np.array([0, 0, 0, 0, 0, 0, 0], dtype=np.float32)

CLUTTER: dict[str, Any] = {
    "task": "clutter",
    "workspace": {"x": [0.35, 0.7], "y": [-0.3, 0.3]},
    "objects": [
        {"name": "cube", "kind": "box", "size": [0.04, 0.04, 0.04], "pose": {"x": [0.4, 0.65], "y": [-0.25, 0.25]}},
    ],
    "clutter": {"n_objects": 7, "seed": 5},
    "success": {"kind": "lifted", "object": "cube", "height": 0.05},
}

WORLD: dict[str, Any] = {
    "task": "vocabulary",
    "objects": [
        {"name": "cube", "kind": "box", "size": [0.04, 0.04, 0.04], "pose": {"x": 0.45, "y": -0.2}},
        {"name": "block", "kind": "box", "size": [0.08, 0.08, 0.05], "movable": False, "pose": {"x": 0.6, "y": -0.2}},
        {
            "name": "disc",
            "kind": "cylinder",
            "size": [0.05, 0.001],
            "visual": True,
            "rgba": [0.1, 0.8, 0.2, 1],
            "pose": {"x": 0.45, "y": 0.05},
        },
        {"name": "drawer", "kind": "drawer", "size": [0.3, 0.25, 0.12], "pose": {"x": 0.75, "y": 0.25}},
    ],
    "success": {"kind": "drawer_opened", "object": "drawer", "distance": 0.1},
}


def _object_geoms(scene: TabletopScene) -> dict[int, str]:
    """Geom id -> object name of every collidable object geom."""
    m = scene.model
    names = {int(m.body(o.name).id): o.name for o in scene.objects if not o.visual}
    out = {}
    for g in range(m.ngeom):
        body = int(m.geom_bodyid[g])
        owner = names.get(body) or names.get(int(m.body_parentid[body]))
        if owner is not None and m.geom_contype[g]:
            out[g] = owner
    return out


def _min_object_distance(scene: TabletopScene) -> float:
    """The smallest distance MuJoCo measures between geoms of two different objects (negative: overlap)."""
    geoms = _object_geoms(scene)
    ids = sorted(geoms)
    best = np.inf
    fromto = np.zeros(6)
    for i, a in enumerate(ids):
        for b in ids[i + 1 :]:
            if geoms[a] != geoms[b]:
                best = min(best, mujoco.mj_geomDistance(scene.model, scene.data, a, b, 0.5, fromto))
    return float(best)


def test_clutter_is_reproducible_per_seed_and_never_overlaps_at_reset() -> None:
    a, b = layout_scene(CLUTTER), layout_scene(CLUTTER)
    try:
        assert [o.name for o in a.objects] == ["cube"] + [f"clutter_{k}" for k in range(7)]
        starts = {}
        for seed in range(12):
            obs = a.reset(seed)
            assert _min_object_distance(a) > 0.005, seed  # footprints 1 cm apart (gap), so surfaces are too
            assert set(obs.privileged["object_poses"]) == {o.name for o in a.objects}
            for name, info in obs.privileged["objects"].items():  # every object rests on the table at reset
                assert info["pos"][2] - info["bottom"] == pytest.approx(0.8, abs=1e-9), name
            starts[seed] = json.dumps(a.initial_state())
            if seed < 3:  # a second instance, same seed: the same scene, bit for bit
                b.reset(seed)
                assert json.dumps(b.initial_state()) == starts[seed]
        assert len(set(starts.values())) == 12  # every seed places them differently
        # a rollout from a reset: the objects stay apart and on the table while physics runs
        a.reset(3)
        for _ in range(10):
            a.step(ZERO)
        assert _min_object_distance(a) > -0.001
    finally:
        a.close()
        b.close()
    other = layout_scene({**CLUTTER, "clutter": {"n_objects": 7, "seed": 6}})
    try:
        sizes = [tuple(other.extents[f"clutter_{k}"].size.round(4)) for k in range(7)]
        assert sizes != [tuple(a.extents[f"clutter_{k}"].size.round(4)) for k in range(7)]  # clutter.seed: the set
    finally:
        other.close()


def test_clutter_that_cannot_fit_is_refused_before_episode_zero() -> None:
    crowded = {**CLUTTER, "clutter": {"n_objects": 30, "size": [0.08, 0.1], "region": {"x": [0.4, 0.5], "y": [0, 0.1]}}}
    with pytest.raises(
        ConfigError,
        match=r"test\.yaml: scene\.params: cannot place 'clutter_\d+' clear of the robot base and the objects",
    ):
        layout_scene(crowded)


def _set_free(scene: TabletopScene, name: str, pos: list[float]) -> None:
    c = scene._free[name]
    scene.data.qpos[c : c + 3] = pos
    scene.data.qpos[c + 3 : c + 7] = [1, 0, 0, 0]
    scene.data.qvel[:] = 0
    mujoco.mj_forward(scene.model, scene.data)


def _holds(scene: TabletopScene, criterion: dict[str, Any]) -> bool:
    return holds(CRITERION.validate_python(criterion), scene)


def test_each_success_criterion_is_true_and_false_on_real_states() -> None:
    scene = layout_scene(WORLD)
    try:
        scene.reset(0)
        h, disc, block = 0.8, scene.pos("disc"), scene.pos("block")
        in_disc = {"kind": "in_region", "object": "cube", "region": "disc"}
        in_box = {"kind": "in_region", "object": "cube", "region": {"x": [0.4, 0.5], "y": [0.0, 0.1]}}
        on_block = {"kind": "on_top", "object": "cube", "support": "block"}
        lifted = {"kind": "lifted", "object": "cube", "height": 0.05}
        opened = {"kind": "drawer_opened", "object": "drawer", "distance": 0.1}

        # the cube rests on the table inside the disc (settled by physics): in the region, not lifted, not on
        _set_free(scene, "cube", [disc[0] + 0.03, disc[1], h + 0.02])
        for _ in range(5):
            scene.step(ZERO)
        assert _holds(scene, in_disc) and _holds(scene, in_box)
        assert not _holds(scene, lifted) and not _holds(scene, on_block)
        # just outside the disc's radius (inside its bounding square): not in the round region
        _set_free(scene, "cube", [disc[0] + 0.04, disc[1] + 0.04, h + 0.02])
        assert not _holds(scene, in_disc) and _holds(scene, in_box)
        # above the disc: in the region but not resting there, and lifted
        _set_free(scene, "cube", [disc[0], disc[1], h + 0.02 + 0.07])
        assert not _holds(scene, in_disc) and _holds(scene, {**in_disc, "resting": False})
        assert _holds(scene, lifted) and not _holds(scene, {**lifted, "height": 0.08})
        # on the block, settled by physics; then beside it at the same height, then on the table next to it
        top = block[2] + 0.025
        _set_free(scene, "cube", [block[0] + 0.02, block[1], top + 0.02 + 0.002])
        for _ in range(10):
            scene.step(ZERO)
        assert _holds(scene, on_block) and not _holds(scene, in_disc)
        assert scene.pos("cube")[2] == pytest.approx(top + 0.02, abs=0.003)
        _set_free(scene, "cube", [block[0] + 0.07, block[1], top + 0.02])
        assert not _holds(scene, on_block)
        _set_free(scene, "cube", [block[0] - 0.1, block[1], h + 0.02])
        assert not _holds(scene, on_block)
        # the support's footprint turns with it: a corner point in and out as the block turns 45 degrees
        corner = [block[0] + 0.035, block[1] + 0.035, top + 0.02]
        side = [block[0] + 0.05, block[1], top + 0.02]
        _set_free(scene, "cube", corner)
        assert _holds(scene, on_block)
        _set_free(scene, "cube", side)
        assert not _holds(scene, on_block)
        mocap = scene._mocap["block"]
        scene.data.mocap_quat[mocap] = [np.cos(np.pi / 8), 0, 0, np.sin(np.pi / 8)]
        _set_free(scene, "cube", corner)
        assert not _holds(scene, on_block)
        _set_free(scene, "cube", side)
        assert _holds(scene, on_block)
        scene.data.mocap_quat[mocap] = [1, 0, 0, 0]
        _set_free(scene, "cube", [block[0] - 0.1, block[1], h + 0.02])  # back on the table beside the block
        # the drawer: closed, a little open, open past the distance; success() is the YAML's criterion
        q = scene._drawers["drawer"][0]
        assert not _holds(scene, opened) and not scene.success()
        scene.data.qpos[q] = 0.05
        mujoco.mj_forward(scene.model, scene.data)
        assert not _holds(scene, opened) and not scene.success()
        scene.data.qpos[q] = 0.15
        mujoco.mj_forward(scene.model, scene.data)
        assert _holds(scene, opened) and scene.success()
        # all / any over the current state (cube on the table beside the block, drawer open)
        assert _holds(scene, {"kind": "all", "of": [opened, {"kind": "any", "of": [lifted, in_box, opened]}]})
        assert not _holds(scene, {"kind": "all", "of": [opened, lifted]})
        assert _holds(scene, {"kind": "any", "of": [lifted, opened]})
        assert not _holds(scene, {"kind": "any", "of": [lifted, on_block]})
    finally:
        scene.close()


def test_drawer_slides_under_a_pull_and_stays_put_without_one() -> None:
    scene = layout_scene(WORLD)
    try:
        obs = scene.reset(0)
        info = obs.privileged["objects"]["drawer"]
        assert info["opening"] == 0.0 and info["max_opening"] == pytest.approx(0.2)
        assert np.allclose(info["open_dir"], [-1, 0, 0])
        # the handle bar sits in front of the cabinet, at mid height, reachable from above
        assert info["handle_pos"][0] < info["pos"][0] - 0.125 - 0.03 and info["handle_pos"][2] == pytest.approx(0.86)
        for _ in range(10):
            obs = scene.step(ZERO).observation
        assert abs(obs.privileged["objects"]["drawer"]["opening"]) < 1e-4  # no drift at rest
        body = scene._drawers["drawer"][1]
        scene.data.xfrc_applied[body, :3] = [-8.0, 0.0, 0.0]  # a pull along open_dir (8 N, as a hand would)
        for _ in range(10):
            obs = scene.step(ZERO).observation
        opening = obs.privileged["objects"]["drawer"]["opening"]
        assert 0.05 < opening <= 0.2 + 1e-3
        assert obs.privileged["object_poses"]["drawer"][0] == pytest.approx(info["pos"][0] - opening, abs=1e-6)
        for _ in range(20):  # the slide's limit stops it
            obs = scene.step(ZERO).observation
        assert obs.privileged["objects"]["drawer"]["opening"] == pytest.approx(0.2, abs=0.005)
    finally:
        scene.close()


def test_mesh_object_loads_and_rests_on_the_table() -> None:
    params = {
        "objects": [
            {"name": "can", "kind": "mesh", "mesh": "can", "mass": 0.2, "pose": {"x": [0.45, 0.55], "y": [-0.1, 0.1]}},
            {
                "name": "lemon",
                "kind": "mesh",
                "mesh": "pkg://robosuite/models/assets/objects/meshes/lemon.stl",
                "rgba": [0.95, 0.9, 0.2, 1],
                "pose": {"x": 0.6, "y": 0.2},
            },
            {  # a MetaWorld mesh (the metaworld extra is part of the default environment)
                "name": "stick",
                "kind": "mesh",
                "mesh": "pkg://metaworld/assets/objects/meshes/stick/stick.stl",
                "pose": {"x": 0.35, "y": -0.25},
            },
        ],
        "success": {"kind": "lifted", "object": "can", "height": 0.05},
    }
    scene = layout_scene(params)
    try:
        obs = scene.reset(2)
        can = obs.privileged["objects"]["can"]
        assert can["kind"] == "mesh" and 0.04 < can["size"][0] < 0.08 and 0.07 < can["size"][2] < 0.14
        start = np.array(can["pos"])
        stick = obs.privileged["objects"]["stick"]
        for _ in range(20):
            obs = scene.step(ZERO).observation
        pose = obs.privileged["object_poses"]["can"]
        assert np.linalg.norm(pose[:3] - start) < 0.003  # it neither sinks nor falls nor slides
        zaxis = np.zeros(9)
        mujoco.mju_quat2Mat(zaxis, pose[3:])
        assert zaxis[8] > 0.999  # upright
        assert np.allclose(stick["size"], [0.1, 0.04, 0.04], atol=0.002)  # MetaWorld's stick lies along x
        assert stick["pos"][2] - stick["bottom"] == pytest.approx(0.8)  # placed on the table top
        lemon = obs.privileged["object_poses"]["lemon"]
        assert lemon[2] > 0.8 and not scene.success()
        assert obs.privileged["roles"] == {"object": "can"} and obs.privileged["task"] == "tabletop_push"
    finally:
        scene.close()


def test_privileged_objects_and_restore_cover_every_object() -> None:
    scene = layout_scene(WORLD)
    try:
        obs = scene.reset(4)
        p = obs.privileged
        assert set(p["objects"]) == {"cube", "block", "disc", "drawer"}
        assert set(p["object_poses"]) == {"cube", "drawer"}  # the movable ones (a drawer: its sliding body)
        assert p["roles"] == {"drawer": "drawer"} and (p["success"] or {}).get("kind") == "drawer_opened"
        assert p["objects"]["block"]["top_z"] == pytest.approx(0.85) and not p["objects"]["block"]["movable"]
        saved = json.loads(json.dumps(scene.initial_state()))
        assert set(saved["object_poses"]) == {"cube", "drawer"}
        _set_free(scene, "cube", [0.5, 0.0, 1.0])
        scene.data.qpos[scene._drawers["drawer"][0]] = 0.1
        restored = scene.reset_to(saved).privileged["object_poses"]
        for name, pose in saved["object_poses"].items():
            assert np.array_equal(restored[name], pose), name
    finally:
        scene.close()


def test_the_task_label_of_a_push_scene_cannot_be_changed() -> None:
    scene = shipped_scene("push", params={"task": "other"})
    from openral_data.runtime import registry
    from tests.support.mujoco import expert_rskill

    with pytest.raises(ConfigError, match=r"scene\.params\.task: scene type 'tabletop_push' is the task 'push'"):
        registry.SCENES["tabletop_push"](scene, registry.ROBOTS["franka_panda"], expert_rskill("push"), "s.yaml")


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (
            {"success": {"kind": "on_top", "object": "cube", "support": "tray"}},
            r"scene\.params\.success\.support: no object 'tray' \(declared: cube, clutter_0",
        ),
        (
            {"objects": [{"name": "cube", "kind": "box", "size": [0.04, 0.04], "pose": {"x": 0.5, "y": 0}}]},
            r"scene\.params\.objects\[0\]\.box\.size: Tuple should have at most 3 items|objects\[0\]\.box\.size",
        ),
        (
            {"objects": [{"name": "cube", "kind": "box", "size": [0.04] * 3, "pose": {"x": [0.2, 0.5], "y": 0}}]},
            r"scene\.params\.objects\[0\]\.pose\.x: \[0\.2, 0\.5\] is not inside the workspace \[0\.35, 0\.7\]",
        ),
    ],
)
def test_bad_scene_yaml_is_one_line_naming_file_and_field(tmp_path: Any, change: dict[str, Any], message: str) -> None:
    data = json.loads(json.dumps(shipped_scene("push").model_dump(mode="json")))
    data["scene"]["id"] = data["task"]["scene_id"] = "bad"
    data["scene"]["type"] = "tabletop"
    data["scene"]["params"] = {**CLUTTER, **change}
    path = write_yaml(tmp_path / "bad.yaml", data)
    done = run_cli("record", "--scene", str(path), "--n-episodes", "1", "--out", str(tmp_path / "out"))
    lines = done.stderr.strip().splitlines()
    assert done.returncode == 2 and len(lines) == 1, done.stderr
    assert lines[0].startswith(f"error: {path}: scene.params") and re.search(message, lines[0]), lines[0]
    assert not (tmp_path / "out").exists()


def test_a_mesh_path_leading_out_of_its_package_is_refused() -> None:
    from openral_data.errors import DatasetError

    escape = {
        "name": "x",
        "kind": "mesh",
        "mesh": "pkg://robosuite/../../../../etc/hostname",
        "pose": {"x": 0.5, "y": 0},
    }
    with pytest.raises(DatasetError, match=r"test\.yaml: scene\.params\.objects\[0\]\.mesh: .*leads outside") as info:
        layout_scene({"objects": [escape]})
    assert info.value.code == "dataset.unsafe"
    not_a_mesh = {**escape, "mesh": "pkg://robosuite/__init__.py"}
    with pytest.raises(ConfigError, match=r"objects\[0\]\.mesh: pkg://robosuite/__init__\.py: not a mesh file"):
        layout_scene({"objects": [not_a_mesh]})


def test_the_documented_example_scene_builds_and_resets(tmp_path: Any) -> None:
    from openral_data.runtime import registry
    from openral_data.schemas.scene import load_recordable_scene
    from tests.support.home import REPO
    from tests.support.mujoco import expert_rskill

    doc = (REPO / "docs/scenes.md").read_text()
    section = doc[doc.index("### Tabletop scenes as data") :]
    block = section[section.index("```yaml\n") + 8 : section.index("```\n", section.index("```yaml\n") + 8)]
    path = tmp_path / "my_stack.yaml"
    path.write_text(block)
    loaded = load_recordable_scene(path)
    scene = registry.SCENES[loaded.scene.type](
        loaded, registry.ROBOTS["franka_panda"], expert_rskill("push"), str(path)
    )
    try:
        assert isinstance(scene, TabletopScene) and scene.task_kind == "stack"
        obs = scene.reset(0)
        assert set(obs.privileged["objects"]) == {
            "red",
            "green",
            "can",
            "drawer",
            "clutter_0",
            "clutter_1",
            "clutter_2",
        }
        assert obs.privileged["roles"] == {"object": "red", "support": "green", "goal": "green", "drawer": "drawer"}
        assert _min_object_distance(scene) > 0.005 and not scene.success()
        assert obs.images["front"].shape == (256, 256, 3)
    finally:
        scene.close()


def test_a_top_down_gripper_closes_on_the_handle_and_pulls_the_drawer_open() -> None:
    """Not an expert (another task's): straight scripted moves show the handle is graspable and the slide sane."""
    drawer = {"name": "drawer", "kind": "drawer", "size": [0.3, 0.25, 0.12], "pose": {"x": 0.68, "y": 0.0}}
    scene = layout_scene(
        {"objects": [drawer], "success": {"kind": "drawer_opened", "object": "drawer", "distance": 0.12}}
    )
    try:
        obs = scene.reset(0)
        handle = obs.privileged["objects"]["drawer"]["handle_pos"]

        def go(target: np.ndarray, grip: float) -> None:
            nonlocal obs
            for _ in range(80):
                delta = target - obs.privileged["ee_pos"]
                if np.linalg.norm(delta) < 0.004:
                    return
                delta *= min(1.0, 0.02 / np.linalg.norm(delta))
                obs = scene.step(np.array([*delta, 0, 0, 0, grip], dtype=np.float32)).observation
            raise AssertionError(f"did not reach {target}: {obs.privileged['ee_pos']}")

        go(np.array([handle[0], handle[1], 1.0]), 0.0)  # above the bar, fingers open across y
        go(handle + np.array([0, 0, 0.01]), 0.0)  # down around it: nothing of the hand touches the cabinet
        m, d = scene.model, scene.data
        cabinet = int(m.body("drawer").id)
        touching = {
            (m.geom(c.geom1).name, m.geom(c.geom2).name)
            for c in d.contact[: d.ncon]
            if cabinet in (m.geom_bodyid[c.geom1], m.geom_bodyid[c.geom2])
        }
        assert not touching, touching
        for _ in range(10):
            obs = scene.step(np.array([0, 0, 0, 0, 0, 0, 1], dtype=np.float32)).observation
        assert 0.5 < obs.privileged["gripper"] < 0.95  # closed on the bar, not on nothing
        success = False
        for _ in range(30):
            result = scene.step(np.array([-0.01, 0, 0, 0, 0, 0, 1], dtype=np.float32))
            success = success or result.success
        assert success and result.observation.privileged["objects"]["drawer"]["opening"] > 0.12
    finally:
        scene.close()


def test_mesh_clutter_is_placed_apart_and_stays_on_the_table() -> None:
    params = {
        **CLUTTER,
        "objects": [],
        "success": {"kind": "lifted", "object": "clutter_0", "height": 0.05},
        "clutter": {"n_objects": 5, "seed": 1, "kinds": ["can", "milk", "bread", "box"]},
    }
    scene = layout_scene(params)
    try:
        kinds = [o.kind for o in scene.objects]
        assert "mesh" in kinds and len(kinds) == 5
        for seed in (0, 1):
            obs = scene.reset(seed)
            assert _min_object_distance(scene) > 0.005
            start = {k: v.copy() for k, v in obs.privileged["object_poses"].items()}
            for _ in range(10):
                obs = scene.step(ZERO).observation
            for name, pose in obs.privileged["object_poses"].items():
                assert np.linalg.norm(pose[:3] - start[name][:3]) < 0.005, name  # resting, not falling or sliding
    finally:
        scene.close()


def test_a_clutter_scene_records_and_replays_with_every_object_restored(tmp_path: Any) -> None:
    """record (scripted pick-place on a `tabletop` scene with clutter) -> replay: every episode reproduced, every
    object's initial pose restored exactly (replay's object error over all of `object_poses`)."""
    import yaml

    from openral_data.record.options import RecordOptions
    from openral_data.record.sim import record
    from openral_data.replay import ReplayOptions, replay
    from openral_data.replay.recorded import RecordedDataset
    from tests.support.home import isolated_home
    from tests.support.replay import SMALL_FRONT

    with isolated_home(tmp_path) as home:
        data = yaml.safe_load((home / "scenes/sim/tabletop_pick_place.yaml").read_text())
        data["scene"]["id"] = data["task"]["scene_id"] = "clutter_pick"
        data["scene"]["type"] = "tabletop"
        data["scene"]["cameras"] = [SMALL_FRONT]
        data["scene"]["params"]["clutter"] = {"n_objects": 3, "seed": 2, "region": {"x": [0.3, 0.7], "y": [-0.4, 0.4]}}
        path = write_yaml(home / "scenes/sim/clutter_pick.yaml", data)
        summary = record(
            RecordOptions(scene=str(path), rskill="scripted-pick-place", n_episodes=2, seed=1, out=tmp_path / "d")
        )
        assert summary.success_rate == 1.0
        recorded = RecordedDataset(summary.out)
        start = recorded.episode(0).initial_state
        assert start is not None and start["task"] == "clutter_pick"
        assert set(start["object_poses"]) == {"cube", "clutter_0", "clutter_1", "clutter_2"}
        result = replay(ReplayOptions(summary.out, out=tmp_path / "res"))
        assert result.summary["mode"] == "actions"
    assert result.summary["reproduced"] == 2 and result.summary["success_agree"] == 2
    for o in result.episodes:
        assert o.object_error_initial is not None and o.object_error_initial < 1e-9
        assert o.first_divergence_frame is None


def test_objects_are_never_placed_into_the_robot_base() -> None:
    params = {
        "objects": [],
        "clutter": {
            "n_objects": 6,
            "seed": 0,
            "size": [0.03, 0.04],
            "region": {"x": [-0.15, 0.25], "y": [-0.25, 0.25]},
        },
    }
    scene = layout_scene(params)
    try:
        base = scene.data.xpos[scene.model.body("robot/base").id][:2].copy()
        geoms = _object_geoms(scene)
        for seed in range(5):
            obs = scene.reset(seed)
            for name, info in obs.privileged["objects"].items():
                assert np.linalg.norm(info["pos"][:2] - base) >= 0.15 + info["radius"], (seed, name)
            robot_contacts = [
                (c.geom1, c.geom2)
                for c in scene.data.contact[: scene.data.ncon]
                if (c.geom1 in geoms or c.geom2 in geoms)
                and any(
                    scene.model.body(int(scene.model.geom_bodyid[g])).name.startswith("robot/")
                    for g in (c.geom1, c.geom2)
                )
            ]
            assert not robot_contacts, seed
    finally:
        scene.close()
