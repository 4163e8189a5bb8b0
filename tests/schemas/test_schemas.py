"""Schemas: strict keys, errors naming file and field, scene tiers."""

from __future__ import annotations

from pathlib import Path

import pytest

# ConfigError raises are matched by message on purpose: the file and field it names are the point
from openral_data.errors import ConfigError
from openral_data.schemas import (
    BenchmarkScene,
    DeployScene,
    RobotManifest,
    RSkillManifest,
    SimScene,
    load_model,
    load_recordable_scene,
    load_scene,
)
from tests.support.home import BUILTIN
from tests.support.scenes import mock_scene, write_yaml


def test_shipped_manifests_load() -> None:
    for path in sorted((BUILTIN / "robots").glob("*/robot.yaml")):
        assert load_model(RobotManifest, path).name == path.parent.name
    for path in sorted((BUILTIN / "rskills").glob("*/rskill.yaml")):
        assert load_model(RSkillManifest, path).id == path.parent.name
    tiers = {p.parent.name: type(load_scene(p)) for p in (BUILTIN / "scenes").glob("*/*.yaml")}
    assert tiers == {"sim": SimScene, "benchmark": BenchmarkScene, "deploy": DeployScene}


def _robot(tmp_path: Path, **changes: object) -> Path:
    data = dict(__import__("yaml").safe_load((BUILTIN / "robots/mock_arm/robot.yaml").read_text()))
    data.update(changes)
    return write_yaml(tmp_path / "robot.yaml", data)


def test_unknown_key_names_file_and_field(tmp_path: Path) -> None:
    path = _robot(tmp_path, sensorz={})
    with pytest.raises(ConfigError, match=r"robot\.yaml: sensorz: unknown key"):
        load_model(RobotManifest, path)


def test_nested_field_error_is_located(tmp_path: Path) -> None:
    path = _robot(tmp_path, joints=[{"name": "j", "type": "revolute", "limits": [1.0, -1.0]}])
    with pytest.raises(ConfigError, match=r"robot\.yaml: joints\[0\]: .*limits must be \[lower, upper\]"):
        load_model(RobotManifest, path)
    path = _robot(tmp_path, sensors={"cameras": [{"name": "c", "width": 0, "height": 4}]})
    with pytest.raises(ConfigError, match=r"sensors\.cameras\[0\]\.width"):
        load_model(RobotManifest, path)


def test_contract_names_must_match_dim(tmp_path: Path) -> None:
    data = __import__("yaml").safe_load((BUILTIN / "rskills/zero-mock/rskill.yaml").read_text())
    data["action_contract"]["names"] = ["a", "b"]
    path = write_yaml(tmp_path / "rskill.yaml", data)
    with pytest.raises(ConfigError, match=r"rskill\.yaml: action_contract: .*names has 2 entries but dim is 7"):
        load_model(RSkillManifest, path)
    data["action_contract"] = {**data["state_contract"], "dtype": "float64"}
    path = write_yaml(tmp_path / "rskill.yaml", data)
    with pytest.raises(ConfigError, match=r"action_contract\.dtype"):
        load_model(RSkillManifest, path)


def test_invalid_yaml_and_missing_file(tmp_path: Path) -> None:
    bad = tmp_path / "bad.yaml"
    bad.write_text("tier: sim\nscene: [unclosed\n")
    with pytest.raises(ConfigError, match=r"bad\.yaml \(line \d+\): invalid YAML"):
        load_scene(bad)
    with pytest.raises(ConfigError, match=r"nope\.yaml: file not found"):
        load_scene(tmp_path / "nope.yaml")
    (tmp_path / "list.yaml").write_text("- 1\n- 2\n")
    with pytest.raises(ConfigError, match="expected a mapping"):
        load_scene(tmp_path / "list.yaml")


def test_task_scene_id_must_match(tmp_path: Path) -> None:
    data = mock_scene()
    data["task"]["scene_id"] = "other"
    with pytest.raises(ConfigError, match=r"task\.scene_id 'other' must equal scene\.id 'mock_test'"):
        load_scene(write_yaml(tmp_path / "s.yaml", data))


@pytest.mark.parametrize("key", ["vla", "policy", "rskill"])
def test_policy_block_in_scene_is_refused(tmp_path: Path, key: str) -> None:
    data = {**mock_scene(), key: {"id": "some-policy"}}
    with pytest.raises(ConfigError, match=f"s.yaml: {key}: a scene must not name a policy"):
        load_scene(write_yaml(tmp_path / "s.yaml", data))


def test_tiers_are_strict(tmp_path: Path) -> None:
    data = mock_scene()
    # a sim scene may not carry benchmark metadata
    meta = {**data, "metadata": {"paper": "p", "honest_scope": "s"}}
    with pytest.raises(ConfigError, match="metadata: unknown key"):
        load_scene(write_yaml(tmp_path / "s.yaml", meta))
    # a benchmark scene needs metadata, seed and n_episodes
    bench = {**meta, "tier": "benchmark"}
    assert isinstance(load_scene(write_yaml(tmp_path / "b.yaml", bench)), BenchmarkScene)
    for key in ("metadata", "seed", "n_episodes"):
        partial = {k: v for k, v in bench.items() if k != key}
        with pytest.raises(ConfigError, match=f"{key}: Field required"):
            load_scene(write_yaml(tmp_path / "b.yaml", partial))
    # a deploy scene has no task
    with pytest.raises(ConfigError, match="task: unknown key"):
        load_scene(write_yaml(tmp_path / "d.yaml", {**data, "tier": "deploy"}))
    with pytest.raises(ConfigError, match="tier: must be one of"):
        load_scene(write_yaml(tmp_path / "x.yaml", {**data, "tier": "prod"}))


def test_record_refuses_deploy_scene_with_reason() -> None:
    with pytest.raises(ConfigError, match="deploy scenes have no task"):
        load_recordable_scene(BUILTIN / "scenes/deploy/mock_workcell.yaml")
    assert isinstance(load_recordable_scene(BUILTIN / "scenes/benchmark/mock_pick_bench.yaml"), BenchmarkScene)


@pytest.mark.parametrize("tier", [[], {"a": 1}, None, 3])
def test_a_tier_that_is_not_a_string_is_one_line(tmp_path: Path, tier: object) -> None:
    with pytest.raises(ConfigError, match="tier: must be one of"):
        load_scene(write_yaml(tmp_path / "s.yaml", {**mock_scene(), "tier": tier}))
