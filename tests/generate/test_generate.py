"""`openral-data generate`: MimicGen-style generation from a few source demonstrations (docs/generate.md)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow.parquet as pq
import pytest

from openral_data.generate.segments import cuts
from openral_data.generate.trace import Trace
from openral_data.policies.mimicgen.plan import Demo, Plan, Segment, write_plan
from openral_data.policies.mimicgen.policy import MimicGenPolicy
from openral_data.policies.mimicgen.poses import compose, inverse, rotate
from openral_data.runtime import registry
from openral_data.types import Observation
from tests.cli.test_json import parse
from tests.support.inproc import run_inproc
from tests.support.mujoco import FRONT, shipped_scene
from tests.support.scenes import write_yaml

SMALL = FRONT.model_copy(update={"width": 48, "height": 48})


def small_scene(tmp: Path, kind: str, randomize: dict[str, Any] | None = None) -> Path:
    params = {"randomize": randomize} if randomize is not None else None
    doc = shipped_scene(kind, [SMALL], params=params).model_dump(mode="json", exclude_none=True)
    doc["scene"]["id"] = doc["task"]["scene_id"] = f"{kind}_small"
    return write_yaml(tmp / f"{kind}.yaml", doc)


def rows(out: Path) -> list[dict[str, Any]]:
    return [r for f in sorted((out / "meta" / "episodes").rglob("*.parquet")) for r in pq.read_table(f).to_pylist()]


@pytest.fixture(scope="module")
def source(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """Two scripted pick-place demonstrations (the scene, the dataset)."""
    tmp = tmp_path_factory.mktemp("src")
    scene = small_scene(tmp, "pick_place")
    out = tmp / "src"
    r = run_inproc("record", "--scene", str(scene), "--n-episodes", "2", "--out", str(out), "--codec", "h264")
    assert r.returncode == 0, r.stderr
    return scene, out


def test_generate_pick_place(source: tuple[Path, Path], tmp_path: Path) -> None:
    scene, src = source
    out = tmp_path / "gen"
    r = run_inproc(
        "generate", str(src), "--scene", str(scene), "--n", "4", "--out", str(out), "--codec", "h264", "--json"
    )
    assert r.returncode == 0, r.stderr
    doc = parse(r.stdout, "generate")  # the fields docs/scripting.md lists, in its order and types
    assert doc["asked"] == 4 and doc["kept"] == 4 and doc["source_episodes"] == 2  # --n: episodes kept
    assert 4 <= doc["attempts"] <= 12 and doc["keep_rate"] == round(4 / doc["attempts"], 4), doc
    episodes = rows(out)
    assert len(episodes) == doc["kept"]
    for row in episodes:
        assert row["openral.success"] is True
        info = json.loads(row["openral.episode_info"])["generated"]
        assert info["source_episode"] in (0, 1)
        assert [s["object"] for s in info["segments"]] == ["cube", "goal"]
        assert info["segments"][0]["source_frames"][0] == 0
    # new object poses: the generated episodes are not the source's
    starts = {json.dumps(json.loads(r["openral.initial_state"])["object_poses"]["cube"]) for r in rows(src)}
    assert not starts & {json.dumps(json.loads(r["openral.initial_state"])["object_poses"]["cube"]) for r in episodes}
    # every kept episode succeeds again when its actions are replayed
    r = run_inproc("replay", str(out), "--mode", "actions", "--json", "--out", str(tmp_path / "res"))
    assert r.returncode == 0, r.stderr
    replayed = json.loads(r.stdout)
    assert replayed["reproduced"] == doc["kept"] and replayed["success_replayed"] == doc["kept"], replayed
    # lerobot 0.6.1 loads it: every frame's action is the one we wrote
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    ds = LeRobotDataset("local/gen", root=out, video_backend="pyav")
    table = pq.read_table(sorted((out / "data").rglob("*.parquet"))[0]).to_pydict()
    assert len(ds) == len(table["action"])
    for i in (0, len(ds) - 1):
        assert np.allclose(ds[i]["action"].numpy(), table["action"][i])


def test_generate_stops_at_the_attempts_cap_and_says_so(source: tuple[Path, Path], tmp_path: Path) -> None:
    scene, src = source
    out = tmp_path / "capped"
    args = ["--n", "3", "--max-attempts", "2", "--out", str(out), "--codec", "h264", "--json"]
    r = run_inproc("generate", str(src), "--scene", str(scene), *args)
    assert r.returncode == 0, r.stderr
    doc = parse(r.stdout, "generate")
    assert (doc["asked"], doc["attempts"]) == (3, 2) and 1 <= doc["kept"] <= 2 and len(rows(out)) == doc["kept"]
    assert f"warning: kept {doc['kept']} of the 3 episodes asked for: the cap of 2 attempts was reached" in r.stderr


def test_generate_into_a_randomized_scene(source: tuple[Path, Path], tmp_path: Path) -> None:
    _, src = source
    block = {
        "light": {"intensity": [0.7, 1.3]},
        "colors": ["table"],
        "physics": {"objects": ["cube"], "mass": [0.8, 1.2]},
    }
    scene = small_scene(tmp_path, "pick_place", block)
    out = tmp_path / "gen"
    r = run_inproc("generate", str(src), "--scene", str(scene), "--n", "3", "--out", str(out), "--codec", "h264")
    assert r.returncode == 0, r.stderr
    for row in rows(out):
        assert "randomization" in json.loads(row["openral.initial_state"])


def trace_of(length: int, close: int, open_: int) -> Trace:
    tr = Trace(episode=0, movable={"cube"})
    for t in range(length):
        grip = 1.0 if close <= t < open_ else 0.0
        ee = np.array([0.5, 0.0, 1.0]) if t <= close + 5 else np.array([0.6, 0.2, 1.0])
        tr.ee_pos.append(ee)
        tr.ee_quat.append(np.array([1.0, 0.0, 0.0, 0.0]))
        cube = ee.copy() if t >= close else np.array([0.5, 0.0, 0.98])
        tr.objects.append(
            {"cube": (cube, np.array([1.0, 0, 0, 0])), "goal": (np.array([0.6, 0.2, 0.9]), np.array([1.0, 0, 0, 0]))}
        )
        tr.actions.append(np.array([0, 0, 0, 0, 0, 0, grip], dtype=np.float32))
    return tr


def test_segments_from_gripper_events() -> None:
    """Close at 10, open at 25 of 30: a grasp segment relative to the cube to 10 + settle, then the goal."""
    assert cuts(trace_of(30, 10, 25), settle=8) == [(18, "cube"), (30, "goal")]
    assert cuts(trace_of(30, 10, 25), settle=40) == [(30, "cube")]


def test_policy_moves_a_segment_with_its_object(tmp_path: Path) -> None:
    """A segment recorded around an object at A is played around the object at B: every target is B A^-1 T."""
    yaw = np.array([np.cos(np.pi / 4), 0.0, 0.0, np.sin(np.pi / 4)])  # 90 degrees about z
    src_obj = (np.array([0.5, 0.0, 0.8]), np.array([1.0, 0.0, 0.0, 0.0]))
    new_obj = (np.array([0.4, 0.1, 0.8]), yaw)
    targets = [np.array([0.5 + 0.01 * k, 0.0, 1.0 - 0.01 * k]) for k in range(6)]
    seg = Segment(
        start=0,
        end=6,
        object="cube",
        object_pos=(0.5, 0.0, 0.8),
        object_quat=(1.0, 0.0, 0.0, 0.0),
        target_pos=[tuple(p) for p in targets],
        target_quat=[(1.0, 0.0, 0.0, 0.0)] * 6,
        gripper=[0.0] * 6,
    )
    write_plan(Plan(source="src", interpolation=0, demos=[Demo(episode=0, segments=[seg])]), tmp_path / "plan.json")
    manifest = registry.resolve_rskill("scripted-pick-place")[0]
    manifest = manifest.model_copy(
        update={"policy": "mimicgen", "policy_extras": {"plan": str(tmp_path / "plan.json")}}
    )
    policy = MimicGenPolicy(manifest)
    policy.reset(0)
    moved = compose(new_obj, inverse(src_obj))
    want = [compose(moved, (p, np.array([1.0, 0, 0, 0])))[0] for p in targets]
    ee = want[0].copy()
    quat = yaw  # the grasp site already posed as the first target: no interpolation
    for k in range(6):
        obs = Observation(
            state=np.zeros(8, np.float32),
            images={},
            task="",
            privileged={
                "ee_pos": ee,
                "ee_quat": quat,
                "objects": {"cube": {"pos": new_obj[0], "quat": new_obj[1]}},
            },
        )
        action = policy.step(obs, "")
        assert np.allclose(ee + action[:3], want[k], atol=1e-6)
        ee = ee + action[:3].astype(np.float64)
    # the segment turned with the object: its x steps became y steps
    assert np.allclose(want[1] - want[0], rotate(yaw, targets[1] - targets[0]))
    assert np.allclose(want[1] - want[0], [0.0, 0.01, -0.01])
    info = policy.episode_info()["generated"]
    assert info["source_episode"] == 0 and info["segments"][0]["object"] == "cube"


def test_bad_inputs_are_one_line(source: tuple[Path, Path], tmp_path: Path) -> None:
    scene, src = source
    notes = tmp_path / "notes.yaml"
    notes.write_text("episodes:\n  0: [{end: 50, object: cube}, {end: 20, object: goal}]\n")
    for args, needle in (
        (["--annotations", str(notes)], "episodes.0"),
        (["--n", "0"], "--n"),
        (["--max-attempts", "0"], "--max-attempts"),
    ):
        out = tmp_path / "x"
        base = ["generate", str(src), "--scene", str(scene), "--n", "2", "--out", str(out)]
        r = run_inproc(*base, *args)
        lines = r.stderr.strip().splitlines()
        assert r.returncode == 2 and len(lines) == 1 and needle in lines[0], r.stderr
        assert not out.exists()
    mock = tmp_path / "mock"
    assert run_inproc("record", "--out", str(mock), "--n-episodes", "1").returncode == 0
    r = run_inproc("generate", str(mock), "--scene", str(scene), "--n", "2", "--out", str(tmp_path / "y"))
    assert r.returncode == 2 and "delta_eef_gripper" in r.stderr, r.stderr
