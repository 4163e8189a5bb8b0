"""lerobot's `observation.environment_state` through `convert`: a lerobot-written dataset that has one keeps it
through LeRobot -> MCAP -> LeRobot (our own bags: the start marker's `environment_state_names` and the
`/environment_state` topic), and a user mapping's `environment_state` role fills it from the bag's messages
(official writers, tests/support/layout_bags.py), every value checked against its source."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from openral_data.doctor import check
from tests.support import layout_bags as lb
from tests.support.cli import run_cli
from tests.support.lerobot_written import ENV_NAMES, LENGTHS, env_state, loaded_episodes, write_lerobot_dataset
from tests.support.scenes import write_yaml

ENV = "observation.environment_state"
FPS = 10


@pytest.mark.slow
def test_lerobot_to_mcap_and_back_keeps_the_environment_state(tmp_path: Path) -> None:
    source = tmp_path / "lr"
    write_lerobot_dataset(source, True, image_camera=True, environment_state=True)
    bags, back = tmp_path / "bags", tmp_path / "back"
    proc = run_cli("convert", str(source), str(bags), "--image-format", "png")
    assert proc.returncode == 0, proc.stderr
    proc = run_cli("convert", str(bags), str(back), "--codec", "h264", "--json")  # the 20x24 image camera: no av1
    assert proc.returncode == 0, proc.stderr
    doc = json.loads(proc.stdout)
    assert "/environment_state" in doc["topics"] and "/environment_state" not in doc["skipped_topics"]
    assert doc["topics"]["/environment_state"]["used"] == sum(LENGTHS)
    feature = json.loads((back / "meta/info.json").read_text())["features"][ENV]
    assert feature == {"dtype": "float32", "shape": [len(ENV_NAMES)], "names": ENV_NAMES}
    got, want = loaded_episodes(back), loaded_episodes(source)  # lerobot 0.6.1 loads both
    assert [[f["env"] for f in ep] for ep in got] == [[f["env"] for f in ep] for ep in want]
    assert [[f["env"] for f in ep] for ep in got] == [
        [env_state(e, t).tolist() for t in range(n)] for e, n in enumerate(LENGTHS)
    ]
    assert [[(f["state"], f["action"]) for f in ep] for ep in got] == [
        [(f["state"], f["action"]) for f in ep] for ep in want
    ]
    assert "observation.environment_state" in json.loads((back / "meta/stats.json").read_text())
    assert check(back) == []  # doctor: healthy


SPLIT_ENV: dict[str, Any] = {
    "fps": FPS,
    "task": "pick",
    "state": {"topic": "/arm/joint_states", "field": "position", "joints": ["j1", "j2", "j3"]},
    "action": {"topic": "/arm/cmd", "field": "data"},
}
SINGLE = {"topic": "/object/pose", "field": "data", "names": ["obj_x", "obj_y", "obj_yaw"]}
PARTS = {
    "parts": [
        {"topic": "/object/pose", "field": "data", "names": ["obj_x", "obj_y", "obj_yaw"]},
        # another role's topic, another field: the gripper's measured effort
        {"topic": "/gripper/joint_states", "field": "effort", "joints": ["finger"], "names": ["grip_effort"]},
    ]
}


def _parts(vector: dict[str, Any]) -> list[dict[str, Any]]:
    parts: list[dict[str, Any]] = vector.get("parts", [vector])
    return parts


@pytest.mark.parametrize(
    ("kind", "env"), [("ros1", SINGLE), ("plain-mcap", PARTS), ("ros2-mcap", PARTS)], ids=["ros1", "plain", "ros2"]
)
def test_mapped_environment_state_matches_the_source_messages(tmp_path: Path, kind: str, env: dict[str, Any]) -> None:
    samples = [*lb.split(), *lb.object_poses()]
    bag = lb.WRITERS[kind](tmp_path, samples)
    mapping = {**SPLIT_ENV, "environment_state": env}
    out = tmp_path / "ds"
    proc = run_cli("convert", str(bag), str(out), "--mapping", str(write_yaml(tmp_path / "m.yaml", mapping)),
                   "--json")  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    doc = json.loads(proc.stdout)
    assert doc["topics"]["/object/pose"]["messages"] == 25 and "/object/pose" not in doc["skipped_topics"]
    names = [n for part in _parts(env) for n in part["names"]]
    assert json.loads((out / "meta/info.json").read_text())["features"][ENV]["names"] == names
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    ds = LeRobotDataset("local/check", root=out)
    roles = [SPLIT_ENV["state"], SPLIT_ENV["action"], *_parts(env)]
    t0 = lb.grid_start(samples, [p["topic"] for p in roles])
    assert len(ds) == 10
    for i in range(len(ds)):
        item = ds[i]
        ns = t0 + int(item["frame_index"]) * (10**9 // FPS)
        want = [v for part in _parts(env) for v in lb.part_values(samples, part, ns)]
        assert np.atleast_1d(item[ENV].numpy()).tolist() == want, (i, ns)
        assert item["observation.state"].numpy().tolist() == lb.part_values(samples, SPLIT_ENV["state"], ns)
    assert check(out) == []  # doctor: healthy


def test_environment_state_mapping_errors(tmp_path: Path) -> None:
    """A bad environment_state role is one line naming it, like state / action."""
    samples = [*lb.split(), *lb.object_poses()]
    bag = lb.write_ros1(tmp_path / "log.bag", samples)
    bad = {**SPLIT_ENV, "environment_state": {"topic": "/object/pose", "field": "data", "names": ["x", "y"]}}
    proc = run_cli("convert", str(bag), str(tmp_path / "ds"), "--mapping", str(write_yaml(tmp_path / "m.yaml", bad)))
    assert proc.returncode == 2
    first = proc.stderr.splitlines()[0]
    assert "environment_state" in first and "names has 2 entries for 3 values" in first, first
    assert not (tmp_path / "ds").exists()
