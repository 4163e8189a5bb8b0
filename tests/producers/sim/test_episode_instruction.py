"""A randomized scene's instruction names the colours each episode really shows: `{NAME.color}` is filled in from
that object's rgba in the episode's model; a colour written out for an object whose colour varies is refused."""

from __future__ import annotations

import colorsys
import json
from pathlib import Path

import pyarrow.parquet as pq
import pytest
import yaml

from openral_data.errors import ConfigError
from openral_data.record.options import RecordOptions
from openral_data.record.sim import record
from openral_data.runtime import registry
from openral_data.schemas.scene import load_recordable_scene
from tests.support.scenes import write_yaml

# what each colour word may mean, as a hue interval in degrees (saturated colours) — independent of our naming
HUE = {"red": [(330, 360), (0, 20)], "green": [(70, 170)], "blue": [(190, 265)], "yellow": [(40, 75)]}


def _means(word: str, rgba: list[float]) -> bool:
    h, s, _ = colorsys.rgb_to_hsv(*rgba[:3])
    return s > 0.2 and any(lo <= h * 360 <= hi for lo, hi in HUE[word])


def _small(project: Path, instruction: str | None = None) -> Path:
    data = yaml.safe_load((project / "scenes/sim/tabletop_pick_place_randomized.yaml").read_text())
    for cam in data["scene"]["cameras"]:
        cam["width"] = cam["height"] = 32
    if instruction is not None:
        data["task"]["instruction"] = instruction
    return write_yaml(project / "scenes/sim/small_randomized.yaml", data)


def test_each_episode_s_instruction_names_its_pad_s_actual_colour(project: Path, tmp_path: Path) -> None:
    out = tmp_path / "rand"
    scene = _small(project)
    record(RecordOptions(scene=str(scene), rskill="scripted-pick-place", n_episodes=3, seed=0, out=out, max_steps=3))
    episodes = pq.read_table(next((out / "meta/episodes").rglob("*.parquet"))).to_pylist()
    said = []
    for row in episodes:
        (task,) = row["tasks"]
        state = json.loads(row["openral.initial_state"])
        pad = state["randomization"]["colors"]["goal"]
        words = task.split()
        assert words[:3] == ["put", "the", "red"] and words[-1] == "pad", task
        assert _means(words[2], [0.85, 0.12, 0.1]) and _means(words[-2], pad), (task, pad)
        said.append(words[-2])
    assert len(set(said)) == 3  # seeds 0, 1, 2: a green, a blue and a red pad

    # the same colours in the scene's model when the episode is set up again
    spec = load_recordable_scene(scene)
    robot, (rskill, _) = registry.ROBOTS["franka_panda"], registry.resolve_rskill("scripted-pick-place")
    env = registry.scene_factory(spec.scene.type, str(scene))(spec, robot, rskill, str(scene))
    try:
        for row, word in zip(episodes, said, strict=True):
            obs = env.reset_to(json.loads(row["openral.initial_state"]))
            goal = env.model.body("goal").id  # type: ignore[attr-defined]
            geom = next(g for g in range(env.model.ngeom) if env.model.geom_bodyid[g] == goal)  # type: ignore[attr-defined]
            assert _means(word, list(env.model.geom_rgba[geom])) and obs.task == row["tasks"][0]  # type: ignore[attr-defined]
    finally:
        env.close()


def test_an_instruction_that_writes_out_a_randomized_colour_is_refused(project: Path) -> None:
    scene = _small(project, "put the red cube on the blue pad")
    spec = load_recordable_scene(scene)
    robot, (rskill, _) = registry.ROBOTS["franka_panda"], registry.resolve_rskill("scripted-pick-place")
    with pytest.raises(ConfigError, match=r"task\.instruction: says 'blue', the colour of 'goal', which randomize"):
        registry.scene_factory(spec.scene.type, str(scene))(spec, robot, rskill, str(scene))
