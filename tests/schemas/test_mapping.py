"""The convert mapping: a state or action is one source or `parts` concatenated in order; roles may share a
topic; mistakes are one line naming the file and the field."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

# ConfigError raises are matched by message on purpose: the file and field it names are the point
from openral_data.errors import ConfigError
from openral_data.schemas.mapping import VectorSource, load_mapping
from tests.support.bags import MAPPING
from tests.support.scenes import write_yaml

ARM = {"topic": "/arm/joint_states", "field": "position", "joints": ["j1", "j2"]}
GRIPPER = {"topic": "/gripper/joint_states", "field": "position", "names": ["finger"]}


def _load(tmp_path: Path, **change: Any) -> Any:
    return load_mapping(write_yaml(tmp_path / "m.yaml", {**MAPPING, **change}))


def test_single_source_is_one_part(tmp_path: Path) -> None:
    m = _load(tmp_path)
    assert m.state.sources() == [VectorSource(topic="/joint_states", field="position", joints=["j1", "j2", "j3"])]
    assert m.state.labels() == [""]


def test_parts_in_order_and_shared_topics(tmp_path: Path) -> None:
    m = _load(
        tmp_path,
        state={"parts": [ARM, GRIPPER]},
        action={"topic": "/arm/joint_states", "field": "velocity", "joints": ["j1", "j2"]},
        reward={"topic": "/arm/joint_states", "field": "header.stamp.sec"},
        success={"topic": "/arm/joint_states", "field": "position"},
    )
    assert [p.topic for p in m.state.sources()] == ["/arm/joint_states", "/gripper/joint_states"]
    assert m.state.labels() == ["parts[0]", "parts[1]"]
    # every role may read its own field of one topic; the aligned topics are listed once
    assert m.topics() == ["/arm/joint_states", "/gripper/joint_states", "/cam/image_raw", "/cam2/compressed"]


@pytest.mark.parametrize(
    ("state", "message"),
    [
        ({"parts": []}, "state: parts must be a non-empty list"),
        ({"field": "position"}, "state: needs topic (one source) or parts (several, concatenated in"),
        ({"topic": "/x", "parts": [ARM]}, "state: topic beside parts: give each part its own topic"),
        ({"parts": [ARM, {**ARM, "names": ["a", "j2"]}]}, "parts[0] and parts[1] both name a dimension 'j2'"),
        (
            {"parts": [{"topic": "/a", "field": "data"}, {"topic": "/a", "field": "data"}]},
            "parts[0] and parts[1] both name a dimension '/a.data' (give each part its own names)",
        ),
        ({"parts": [{**ARM, "field": "a..b"}]}, "state.parts[0]: field 'a..b' is not a dotted field"),
        ({"parts": [{**ARM, "names": ["x"]}]}, "state.parts[0]: names has 1 entries but joints has 2"),
        ({"parts": [{"field": "data"}]}, "state.parts[0].topic: Field required"),
    ],
)
def test_vector_mistakes_are_one_line(tmp_path: Path, state: dict[str, Any], message: str) -> None:
    with pytest.raises(ConfigError) as excinfo:
        _load(tmp_path, state=state)
    assert str(excinfo.value).startswith(f"{tmp_path / 'm.yaml'}: ") and message in str(excinfo.value)


def test_a_camera_topic_stays_a_camera(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="reward topic /cam/image_raw is also mapped as a camera"):
        _load(tmp_path, reward={"topic": "/cam/image_raw", "field": "height"})


def test_environment_state_is_an_optional_vector_role(tmp_path: Path) -> None:
    """`environment_state` takes the form of state / action; its parts are aligned topics after theirs."""
    assert _load(tmp_path).environment_state is None and [r for r, _ in _load(tmp_path).vectors()] == [
        "state",
        "action",
    ]
    pose = {"topic": "/object/pose", "field": "data", "names": ["x", "y"]}
    m = _load(tmp_path, environment_state={"parts": [pose, GRIPPER]})
    assert [r for r, _ in m.vectors()] == ["state", "action", "environment_state"]
    assert [(r, s.topic) for r, s in m.vector_sources()][-2:] == [
        ("environment_state", "/object/pose"),
        ("environment_state", "/gripper/joint_states"),
    ]
    assert "/object/pose" in m.topics()
    with pytest.raises(ConfigError) as excinfo:
        _load(tmp_path, environment_state={"topic": "/x", "parts": [pose]})
    assert "environment_state: topic beside parts" in str(excinfo.value)
