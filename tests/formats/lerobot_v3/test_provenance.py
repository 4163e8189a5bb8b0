"""meta/openral.json through its model: every writer's key order, and tolerant reading of what is not ours."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from openral_data.errors import DatasetError
from openral_data.formats.lerobot_v3.provenance import (
    EditRecord,
    EditSource,
    HalOrigin,
    Origin,
    Provenance,
    Recorded,
    ReplayOrigin,
    SafetyRecord,
    read_provenance,
)

SCENE = {"tier": "sim", "scene": {"id": "s"}}
RSKILL = {"id": "r"}


def test_each_writer_keeps_its_key_order() -> None:
    assert list(Origin("1", scene=Recorded("a", SCENE), rskill=Recorded("b", RSKILL), robot="x").to_json()) == [
        "openral_data_version",
        "scene",
        "rskill",
        "robot",
    ]
    hal = Origin(
        "1",
        hal=HalOrigin("x", "sim", "K", None),
        rskill=Recorded("b", RSKILL),
        robot="x",
        safety=SafetyRecord("clip", {}),
    )
    assert list(hal.to_json()) == ["openral_data_version", "hal", "rskill", "robot", "safety"]
    replayed = Origin(
        "1", Recorded("a", SCENE), rskill=Recorded("b", RSKILL), robot="x", replayed_from=ReplayOrigin("d", "actions")
    )
    assert list(replayed.to_json()) == ["openral_data_version", "scene", "rskill", "robot", "replayed_from"]
    assert list(Origin("1", converted_from="bag", mapping={}).to_json()) == [
        "openral_data_version",
        "converted_from",
        "mapping",
    ]


def test_round_trip_is_byte_identical(tmp_path: Path) -> None:
    origin = Origin("1", Recorded("a", SCENE), rskill=Recorded("b", RSKILL), robot="x")
    edit = EditRecord("merge", [EditSource("/d", [0, 2], origin)], {"codec": "av1"})
    written = Provenance(origin, {"codec": "av1"}, edit=edit).dumps()
    (tmp_path / "meta").mkdir()
    (tmp_path / "meta/openral.json").write_bytes(written)
    read = read_provenance(tmp_path)
    assert read is not None and read.dumps() == written
    assert read.origin is not None and (read.origin.scene_id, read.origin.rskill_id) == ("s", "r")


def test_reading_is_tolerant(tmp_path: Path) -> None:
    assert read_provenance(tmp_path) is None  # lerobot's own dataset: no file
    (tmp_path / "meta").mkdir()
    path = tmp_path / "meta/openral.json"
    odd = {"writer": "openral-data", "schema_metadata": {"robot": 5, "scene": None, "new": 1}, "config": None}
    path.write_text(json.dumps(odd))
    read = read_provenance(tmp_path)
    assert read is not None and read.origin is not None
    assert read.origin.robot is None and read.origin.present("robot") and read.origin.present("scene")
    assert not read.origin.present("rskill") and read.origin.scene_id is None
    assert read.origin.extra == {"robot": 5, "scene": None, "new": 1}  # kept, written back as they were
    path.write_text(json.dumps({"schema_metadata": []}))
    read = read_provenance(tmp_path)
    assert read is not None and read.origin is None
    path.write_text("[]")
    with pytest.raises(DatasetError, match=r"openral\.json: expected a JSON object, got list"):
        read_provenance(tmp_path)
