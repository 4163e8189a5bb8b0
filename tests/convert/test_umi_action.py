"""A UMI replay buffer as UMI writes it has no ``action`` array (tests/support/replay_buffer.py's `umi_episodes`:
its real key set). `convert` gives it the action UMI's own training code derives (per robot, eef_pos +
eef_rot_axis_angle + gripper_width of the same step), through the starting mapping, where `--print-mapping` shows
it as a guess; a store that has ``data/action`` keeps it. Every action row is checked against that derivation
computed here with zarr and numpy alone, and lerobot 0.6.1 loads the output frame-exact. A mapping part's
`offset: N` (array sources; bags refuse it) takes step t + N instead, the last step holding: the next step's pose."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
import zarr

from openral_data.replay.recorded import RecordedDataset
from openral_data.schemas.mapping import Vector
from tests.support.array_sources import converted_episodes, lerobot_matches_ours
from tests.support.bags import MAPPING, write_ros1
from tests.support.inproc import run_inproc
from tests.support.replay_buffer import umi_episodes, write_replay_buffer, write_umi_buffer

LENGTHS = (6, 4, 7)
UMI_POSE = ("eef_pos", "eef_rot_axis_angle", "gripper_width")


@pytest.fixture(scope="module")
def store(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return write_umi_buffer(tmp_path_factory.mktemp("umi") / "dataset.zarr.zip", umi_episodes(LENGTHS, size=(32, 32)))


def _zarr_episodes(path: Path) -> list[dict[str, np.ndarray[Any, Any]]]:
    """Each episode's rows of every data array, as zarr itself reads the zip store."""
    store = zarr.storage.ZipStore(path, mode="r")
    root: Any = zarr.open_group(store, mode="r")
    ends = [int(e) for e in root["meta/episode_ends"][:]]
    data = {k: np.asarray(a[:]) for k, a in root["data"].arrays()}
    store.close()
    return [{k: v[s:e] for k, v in data.items()} for s, e in zip([0, *ends[:-1]], ends, strict=True)]


def _umi_action(rows: dict[str, np.ndarray[Any, Any]], robots: int = 1) -> np.ndarray[Any, Any]:
    """UMI's SequenceSampler without an action array: robot by robot, its pose and gripper width of the step."""
    return np.concatenate([rows[f"robot{r}_{what}"] for r in range(robots) for what in UMI_POSE], axis=-1)


@pytest.mark.slow  # converts and loads the output with lerobot (~7 s)
def test_a_umi_store_without_action_converts_with_umis_action(store: Path, tmp_path: Path) -> None:
    out = tmp_path / "out"
    want = _zarr_episodes(store)
    assert "action" not in want[0] and len(want) == len(LENGTHS)
    tables = converted_episodes(store, out, len(LENGTHS), "--fps", "60")
    for w, rows in zip(want, tables, strict=True):
        assert rows.column("action").to_pylist() == _umi_action(w).astype(np.float32).tolist()
        state = np.concatenate([w[k] for k in sorted(w) if k != "camera0_rgb"], axis=-1).astype(np.float32)
        assert rows.column("observation.state").to_pylist() == state.tolist()
    info = json.loads((out / "meta" / "info.json").read_text())
    assert info["features"]["action"]["names"] == [
        *(f"robot0_eef_pos_{i}" for i in range(3)),
        *(f"robot0_eef_rot_axis_angle_{i}" for i in range(3)),
        "robot0_gripper_width_0",
    ]
    lerobot_matches_ours(out, RecordedDataset(out))


def test_print_mapping_shows_the_derivation_as_a_guess_and_converts_as_printed(store: Path, tmp_path: Path) -> None:
    run = run_inproc("convert", str(store), "--print-mapping", "--json")
    assert run.returncode == 0, run.stderr
    doc = json.loads(run.stdout)
    parts = [p["topic"] for p in doc["mapping"]["action"]["parts"]]
    assert parts == [f"data/robot0_{what}" for what in UMI_POSE]
    assert "UMI's training code" in doc["guesses"]["action"]
    run = run_inproc("convert", str(store), "--print-mapping", "--fps", "60")
    assert run.returncode == 0, run.stderr
    lines = run.stdout.splitlines()
    at = lines.index("action:")
    assert lines[at - 1].startswith("# guess: no data/action: UMI's training code"), run.stdout
    # the user's override: the printed mapping, edited to drop the gripper from the action
    mapping = yaml.safe_load(run.stdout)
    mapping["action"]["parts"] = mapping["action"]["parts"][:2]
    (tmp_path / "m.yaml").write_text(yaml.safe_dump(mapping))
    tables = converted_episodes(store, tmp_path / "out", len(LENGTHS), "--mapping", str(tmp_path / "m.yaml"))
    for w, rows in zip(_zarr_episodes(store), tables, strict=True):
        pose = np.concatenate([w["robot0_eef_pos"], w["robot0_eef_rot_axis_angle"]], axis=-1)
        assert rows.column("action").to_pylist() == pose.tolist()


def test_two_grippers_give_two_robots_actions_in_order(tmp_path: Path) -> None:
    """UMI's bimanual buffers: robot0's 7 numbers, then robot1's (the sampler's order)."""
    episodes = umi_episodes((3, 2), size=(4, 4))
    for ep, other in zip(episodes, umi_episodes((3, 2), seed=1, size=(4, 4)), strict=True):
        ep.update({k.replace("robot0", "robot1"): v for k, v in other.items() if k.startswith("robot0")})
    path = write_replay_buffer(tmp_path / "bimanual.zarr", episodes)
    run = run_inproc("convert", str(path), "--print-mapping", "--json")
    assert run.returncode == 0, run.stderr
    parts = [p["topic"] for p in json.loads(run.stdout)["mapping"]["action"]["parts"]]
    assert parts == [f"data/robot{r}_{what}" for r in (0, 1) for what in UMI_POSE]


def test_a_store_with_an_action_array_keeps_it(tmp_path: Path) -> None:
    episodes = umi_episodes((3, 2), size=(4, 4))
    for ep in episodes:
        ep["action"] = (ep["robot0_eef_pos"] * 2).astype(np.float32)
    path = write_replay_buffer(tmp_path / "with_action.zarr", episodes)
    run = run_inproc("convert", str(path), "--print-mapping", "--json")
    assert run.returncode == 0, run.stderr
    doc = json.loads(run.stdout)
    assert doc["mapping"]["action"]["topic"] == "data/action" and "action" not in doc["guesses"]


def test_no_action_and_no_umi_pose_is_one_line(tmp_path: Path) -> None:
    episodes = [{"state": ep["robot0_eef_pos"]} for ep in umi_episodes((3, 2), size=(4, 4))]
    path = write_replay_buffer(tmp_path / "stateonly.zarr", episodes)
    out = tmp_path / "out"
    run = run_inproc("convert", str(path), str(out), "--fps", "10")
    assert run.returncode == 2 and run.stderr.count("\n") == 1, run.stderr
    assert run.stderr.startswith(f"error: {path}: data/action: missing") and not out.exists()


def test_offset_1_gives_the_next_steps_pose_the_last_step_holding(
    store: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr("openral_data.convert.from_arrays.MAX_CHUNK_ROWS", 3)  # offsets across chunk boundaries
    run = run_inproc("convert", str(store), "--print-mapping", "--fps", "60")
    mapping = yaml.safe_load(run.stdout)
    for part in mapping["action"]["parts"]:
        part["offset"] = 1
    (tmp_path / "m.yaml").write_text(yaml.safe_dump(mapping))
    tables = converted_episodes(store, tmp_path / "out", len(LENGTHS), "--mapping", str(tmp_path / "m.yaml"))
    for w, rows in zip(_zarr_episodes(store), tables, strict=True):
        action = _umi_action(w)
        following = action[np.minimum(np.arange(len(action)) + 1, len(action) - 1)]
        assert rows.column("action").to_pylist() == following.astype(np.float32).tolist()
        assert rows.column("action").to_pylist()[-1] == rows.column("action").to_pylist()[-2]


def test_offset_in_the_single_source_form_and_not_beside_parts() -> None:
    assert Vector(topic="data/state", offset=2).sources()[0].offset == 2
    assert Vector(topic="data/state").sources()[0].offset == 0
    with pytest.raises(ValueError, match="offset beside parts"):
        Vector(offset=1, parts=[{"topic": "data/state"}])  # type: ignore[list-item]


def test_a_bag_mapping_with_an_offset_is_one_line(tmp_path: Path) -> None:
    bag = write_ros1(tmp_path / "robot.bag")
    (tmp_path / "m.yaml").write_text(yaml.safe_dump({**MAPPING, "action": {**MAPPING["action"], "offset": 1}}))
    out = tmp_path / "out"
    run = run_inproc("convert", str(bag), str(out), "--mapping", str(tmp_path / "m.yaml"))
    assert run.returncode == 2 and run.stderr.count("\n") == 1, run.stderr
    assert run.stderr.startswith(f"error: {bag}: action.offset: array sources only") and not out.exists()
    parts = {"parts": [{"topic": MAPPING["action"]["topic"], "offset": 1}]}  # named where it is: parts[0]
    (tmp_path / "m.yaml").write_text(yaml.safe_dump({**MAPPING, "action": parts}))
    run = run_inproc("convert", str(bag), str(out), "--mapping", str(tmp_path / "m.yaml"))
    assert run.returncode == 2 and run.stderr.count("\n") == 1, run.stderr
    assert run.stderr.startswith(f"error: {bag}: action.parts[0].offset: array sources only") and not out.exists()
