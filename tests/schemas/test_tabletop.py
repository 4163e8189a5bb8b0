"""Tabletop layout schema: per-kind sizes, the success vocabulary, cross-checks naming the field, roles."""

from __future__ import annotations

from typing import Any

import pytest

# ConfigError raises are matched by message on purpose: the file and field it names are the point
from openral_data.errors import ConfigError
from openral_data.schemas.base import parse_yaml, validate
from openral_data.schemas.mujoco import TabletopParams
from openral_data.schemas.tabletop import derived_roles, leaves

SOURCE = "s.yaml: scene.params"
CUBE = {"name": "cube", "kind": "box", "size": [0.04, 0.04, 0.04], "pose": {"x": [0.45, 0.6], "y": 0.0}}
PAD = {"name": "pad", "kind": "box", "size": [0.1, 0.1, 0.02], "movable": False, "pose": {"x": 0.5, "y": 0.2}}


def _load(data: dict[str, Any]) -> TabletopParams:
    from openral_data.schemas.tabletop import check_layout

    params = validate(TabletopParams, data, SOURCE)
    check_layout(params, params.table_top, SOURCE)
    return params


def test_a_layout_with_every_kind_loads_and_derives_its_roles() -> None:
    params = _load(
        {
            "objects": [
                CUBE,
                PAD,
                {"name": "ball", "kind": "sphere", "size": [0.02], "pose": {"x": 0.4, "y": -0.2, "yaw": [-1, 1]}},
                {"name": "can", "kind": "cylinder", "size": [0.03, 0.1], "pose": {"x": 0.6, "y": -0.2}},
                {"name": "milk", "kind": "mesh", "mesh": "milk", "pose": {"x": 0.3, "y": 0.3}},
                {"name": "drawer", "kind": "drawer", "pose": {"x": 0.8, "y": 0.3}},
                {"name": "disc", "kind": "cylinder", "size": [0.05, 0.001], "visual": True, "pose": {"x": 0.5, "y": 0}},
            ],
            "clutter": {"n_objects": 3},
            "success": {
                "kind": "all",
                "of": [
                    {"kind": "on_top", "object": "cube", "support": "pad"},
                    {"kind": "any", "of": [{"kind": "drawer_opened", "object": "drawer", "distance": 0.1}]},
                    {"kind": "in_region", "object": "clutter_2", "region": {"x": [0, 1], "y": [-1, 1]}},
                ],
            },
            "roles": {"distractor": "milk"},
        }
    )
    assert [o.is_movable for o in params.objects] == [True, False, True, True, True, False, False]
    assert [loc for loc, _ in leaves(params.success)] == ["success.of[0]", "success.of[1].of[0]", "success.of[2]"]  # type: ignore[arg-type]
    assert derived_roles(params) == {
        "object": "cube",
        "support": "pad",
        "goal": "pad",
        "drawer": "drawer",
        "distractor": "milk",
    }


@pytest.mark.parametrize(
    ("data", "message"),
    [
        (
            {"objects": [{**CUBE, "size": [0.04, 0.04]}]},
            r"^s\.yaml: scene\.params: objects\[0\]\.box\.size\[2\]: Field required$",
        ),
        ({"objects": [{**CUBE, "kind": "blob"}]}, r"objects\[0\]: Input tag 'blob' found using 'kind'"),
        ({"objects": [{**CUBE, "colour": "red"}]}, r"objects\[0\]\.box\.colour: unknown key"),
        ({"objects": [{**CUBE, "mesh": "x"}]}, r"objects\[0\]\.box\.mesh: unknown key"),
        ({"objects": [{**CUBE, "kind": "mesh", "size": None, "mesh": "teapot"}]}, r"size: unknown key"),
        ({"objects": [{**CUBE, "rgba": [2, 0, 0, 1]}]}, r"objects\[0\]\.box: rgba: each component"),
        ({"objects": [CUBE, CUBE]}, r"^s\.yaml: scene\.params\.objects\[1\]\.name: 'cube' is declared twice$"),
        ({"objects": [{**CUBE, "name": "floor"}]}, r"objects\[0\]\.name: 'floor' is reserved"),
        ({"objects": [{**CUBE, "name": "clutter_1"}]}, r"objects\[0\]\.name: 'clutter_1' is reserved"),
        (
            {"objects": [{**CUBE, "pose": {"x": 0.5, "y": 0, "near": {"object": "pad", "distance": [0.1, 0.2]}}}, PAD]},
            r"objects\[0\]\.pose\.near\.object: 'pad' is not an object declared before 'cube'",
        ),
        (
            {"objects": [{**CUBE, "pose": {"x": [0.5, 1.2], "y": 0}}]},
            r"^s\.yaml: scene\.params\.objects\[0\]\.pose\.x: \[0\.5, 1\.2\] is not inside the table top "
            r"\[-0\.15, 1\.05\]$",
        ),
        (
            {"workspace": {"x": [0.3, 0.7], "y": [-0.3, 0.3]}, "objects": [{**CUBE, "pose": {"x": 0.5, "y": 0.4}}]},
            r"objects\[0\]\.pose\.y: \[0\.4, 0\.4\] is not inside the workspace \[-0\.3, 0\.3\]",
        ),
        ({"workspace": {"x": [0.3, 1.7], "y": [-0.3, 0.3]}}, r"workspace\.x: \[0\.3, 1\.7\] leaves the table top"),
        (
            {"objects": [CUBE], "success": {"kind": "lifted", "object": "cub", "height": 0.1}},
            r"^s\.yaml: scene\.params\.success\.object: no object 'cub' \(declared: cube\)$",
        ),
        (
            {
                "objects": [CUBE],
                "success": {"kind": "any", "of": [{"kind": "in_region", "object": "cube", "region": "x"}]},
            },
            r"success\.of\[0\]\.region: no object 'x'",
        ),
        (
            {"objects": [CUBE], "success": {"kind": "drawer_opened", "object": "cube", "distance": 0.1}},
            r"success\.object: 'cube' is not a drawer",
        ),
        (
            {"objects": [CUBE], "success": {"kind": "on_top", "object": "cube", "support": "cube"}},
            r"cannot be on itself",
        ),
        ({"objects": [CUBE], "success": {"kind": "all", "of": []}}, r"success\.all\.of: List should have at least 1"),
        ({"objects": [CUBE], "roles": {"object": "ball"}}, r"roles\.object: no object 'ball'"),
        (
            {"clutter": {"n_objects": 2, "kinds": ["box", "teapot"]}},
            r"clutter: kinds: \['teapot'\] are not",
        ),
        ({"clutter": {"n_objects": 0}}, r"clutter\.n_objects: Input should be greater than or equal to 1"),
        (
            {"objects": [{"name": "d", "kind": "drawer", "movable": True, "pose": {"x": 0.5, "y": 0}}]},
            r"a drawer's cabinet is a fixture",
        ),
    ],
)
def test_bad_layouts_are_one_line_errors_naming_the_field(data: dict[str, Any], message: str) -> None:
    with pytest.raises(ConfigError, match=message) as info:
        _load(data)
    assert "\n" not in str(info.value)


def test_yaml_on_is_a_boolean_so_the_criterion_is_on_top() -> None:
    """`kind: on` in YAML is `true`: the error says which tags exist (on_top among them)."""
    data = parse_yaml("objects: []\nsuccess: {kind: on, object: cube, support: pad}\n", "s.yaml")
    with pytest.raises(ConfigError, match=r"success: Input tag 'True' found using 'kind' .*'on_top'"):
        _load(data)
