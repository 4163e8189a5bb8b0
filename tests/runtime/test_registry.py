"""Registries: SCENES, POLICIES and the auto-discovered ROBOTS; references by id or path."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

# ConfigError raises are matched by message on purpose: the file and field it names are the point
from openral_data.errors import ConfigError, UsageError
from openral_data.runtime import registry
from tests.support.home import BUILTIN


def test_robots_are_discovered_from_folders(project: Path) -> None:
    shipped = list(registry.ROBOTS)
    assert "mock_arm" in shipped and "mock_arm" in registry.ROBOTS and shipped == sorted(shipped)
    shutil.copytree(project / "robots/mock_arm", project / "robots/a_mock_arm")
    text = (project / "robots/a_mock_arm/robot.yaml").read_text().replace("name: mock_arm", "name: a_mock_arm")
    (project / "robots/a_mock_arm/robot.yaml").write_text(text)
    assert list(registry.ROBOTS) == sorted([*shipped, "a_mock_arm"]) and len(registry.ROBOTS) == len(shipped) + 1
    assert registry.ROBOTS["a_mock_arm"].name == "a_mock_arm"
    # the listed valid choices (the first 12 in order; the new one sorts first) are the point of this message, so
    # the wording is matched besides the code
    with pytest.raises(UsageError, match=r"unknown robot 'nope'; valid: a_mock_arm, aloha, ") as excinfo:
        registry.ROBOTS["nope"]
    assert excinfo.value.code == "usage"


def test_robot_name_must_match_folder(project: Path) -> None:
    shutil.copytree(project / "robots/mock_arm", project / "robots/renamed")
    with pytest.raises(ConfigError, match=r"renamed/robot\.yaml: name: 'mock_arm' must equal its folder name"):
        registry.ROBOTS["renamed"]


def test_references_by_id_and_path(project: Path) -> None:
    rs, path = registry.resolve_rskill("zero-mock")
    assert rs.policy == "zero" and path == project / "rskills/zero-mock/rskill.yaml"
    assert registry.resolve_rskill(str(BUILTIN / "rskills/random-mock"))[0].policy == "random"
    assert registry.resolve_scene_path("mock_pick") == project / "scenes/sim/mock_pick.yaml"
    assert registry.resolve_scene_path("mock_workcell") == project / "scenes/deploy/mock_workcell.yaml"
    assert set(registry.SCENES) >= {"mock"} and set(registry.POLICIES) >= {"zero", "random"}


@pytest.mark.parametrize("path", sorted((BUILTIN / "scenes").glob("[sb]*/*.yaml")), ids=lambda p: p.stem)
def test_every_shipped_scene_names_a_default_rskill_for_its_robot(path: Path) -> None:
    """`record --scene ID` without --rskill uses the scene's default_rskill: it must exist and fit the robot."""
    from openral_data.schemas.scene import load_recordable_scene

    scene = load_recordable_scene(path)
    assert scene.scene.default_rskill is not None, path
    rskill, _ = registry.resolve_rskill(scene.scene.default_rskill)
    robot = registry.ROBOTS[scene.scene.robot or ""]
    assert set(rskill.embodiment_tags) & set(robot.embodiment_tags), (path, rskill.id, robot.name)
