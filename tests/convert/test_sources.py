"""Vectors read from bag messages: one part's reader, and a role's parts concatenated."""

from __future__ import annotations

from pathlib import Path

import pytest

from openral_data.convert.sources import VectorParts
from openral_data.errors import BagError
from openral_data.schemas.mapping import Vector


class _Array:
    def __init__(self, *data: float) -> None:
        self.data = list(data)


def test_parts_names_concatenate_in_order_and_default_per_part() -> None:
    vector = Vector(parts=[{"topic": "/arm/cmd", "field": "data"}, {"topic": "/grip", "field": "data", "names": ["g"]}])
    parts = VectorParts("action", vector)
    bag = Path("b.mcap")
    assert parts.readers[0](_Array(1.0, 2.0), bag).tolist() == [1.0, 2.0]
    assert parts.readers[1](_Array(3.5), bag).tolist() == [3.5]
    assert parts.names() == ["arm/cmd.data[0]", "arm/cmd.data[1]", "g"]
    assert [r.label for r in parts.readers] == [
        "mapping: action.parts[0] (/arm/cmd.data)",
        "mapping: action.parts[1] (/grip.data)",
    ]


def test_a_name_given_twice_across_parts_is_one_line() -> None:
    """A fixed name that equals another part's default name: caught once both widths are known."""
    vector = Vector(parts=[{"topic": "/a", "field": "data"}, {"topic": "/b", "field": "data", "names": ["a.data[0]"]}])
    parts = VectorParts("state", vector)
    parts.readers[0](_Array(1.0), Path("b.mcap"))
    parts.readers[1](_Array(2.0), Path("b.mcap"))
    with pytest.raises(BagError) as excinfo:
        parts.names()
    assert excinfo.value.code == "bag.field"
    assert str(excinfo.value) == "mapping: state.parts[1] (/b.data): dimension name 'a.data[0]' is used twice in state"


def test_width_change_names_bag_part_topic_and_field() -> None:
    reader = VectorParts("action", Vector(topic="/cmd", field="data")).readers[0]
    reader(_Array(1.0), Path("x.bag"))
    with pytest.raises(BagError) as excinfo:
        reader(_Array(1.0, 2.0), Path("x.bag"))
    assert str(excinfo.value) == "x.bag: mapping: action (/cmd.data): vector length changed from 1 to 2"
