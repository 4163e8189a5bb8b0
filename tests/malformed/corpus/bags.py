"""Bags: garbage, empty, truncated, wrong containers; and a state or action part that the bag cannot give."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

from tests.malformed.corpus.cases import case
from tests.support.bags import MAPPING
from tests.support.malformed import Workspace


def _bag_case(id: str, make: Callable[[Workspace], Path], names: str, mapping: bool = True) -> None:
    def build(w: Workspace) -> list[str]:
        src = make(w)
        extra = ["--mapping", str(w.yaml("m.yaml", MAPPING))] if mapping else []
        return ["convert", str(src), str(w.root / "o"), "--codec", "h264", *extra]

    case(id, build, names, ("o",))


def _flip_bag(w: Workspace, at: float) -> Path:
    data = bytearray(w.bag.read_bytes())
    for k in range(64):  # a run of flipped bytes inside the message data
        data[int(len(data) * at) + k] ^= 0x5A
    return w.write("flip.mcap", bytes(data))


def _cut_bag(w: Workspace, keep: float) -> Path:
    data = w.bag.read_bytes()
    return w.write("cut.mcap", data[: int(len(data) * keep)])


for _with in (True, False):
    _m = "" if _with else "-own-mapping"
    _bag_case(f"bag-mcap-empty{_m}", lambda w: w.write("e.mcap", b""), r"e\.mcap", _with)
    _bag_case(f"bag-mcap-garbage{_m}", lambda w: w.write("g.mcap", b"\x89MCAP0\r\n" + b"x" * 500), r"g\.mcap", _with)
    _bag_case(f"bag-mcap-truncated-10{_m}", lambda w: _cut_bag(w, 0.1), r"cut\.mcap", _with)
    _bag_case(f"bag-mcap-truncated-90{_m}", lambda w: _cut_bag(w, 0.9), r"cut\.mcap", _with)
    _bag_case(f"bag-ros1-empty{_m}", lambda w: w.write("e.bag", b""), r"e\.bag", _with)
    _bag_case(f"bag-ros1-garbage{_m}", lambda w: w.write("g.bag", b"#ROSBAG V2.0\n" + b"\x00" * 300), r"g\.bag", _with)
    _bag_case(
        f"bag-ros2-metadata-garbage{_m}",
        lambda w: w.write("r2/metadata.yaml", "rosbag2_bagfile_information: 3").parent,
        r"r2",
        _with,
    )
    _bag_case(
        f"bag-ros2-metadata-not-utf8{_m}", lambda w: w.write("r2/metadata.yaml", b"\xff\xfe").parent, r"r2", _with
    )
    _bag_case(f"bag-folder-without-bags{_m}", lambda w: w.write("plain/readme.txt", "hi").parent, r"plain", _with)
    _bag_case(f"bag-mcap-is-a-folder{_m}", lambda w: w.path("d.mcap/x").parent, r"d\.mcap", _with)
    _bag_case(f"bag-mcap-flipped-20{_m}", lambda w: _flip_bag(w, 0.2), r"flip\.mcap", _with)
    _bag_case(f"bag-mcap-flipped-80{_m}", lambda w: _flip_bag(w, 0.8), r"flip\.mcap", _with)


# ---------------------------------------------------------------------------------------------------------------
# convert: a part of a state or action that the bag cannot give (one line naming the bag, the part, its topic)


def _parts_case(id: str, part: dict[str, Any], names: str) -> None:
    def build(w: Workspace) -> list[str]:
        state = {"parts": [MAPPING["state"], part]}
        mapping = w.yaml("m.yaml", {**MAPPING, "state": state})
        return ["convert", str(w.bag), str(w.root / "o"), "--codec", "h264", "--mapping", str(mapping)]

    case(id, build, names, ("o",))


_parts_case(
    "mapping-part-missing-topic", {"topic": "/gripper"}, r"log\.mcap: mapped topic\(s\) /gripper not in the bag"
)
_parts_case(
    "mapping-part-not-numbers",
    {"topic": "/joint_states", "field": "name", "names": ["n"]},
    r"log\.mcap: mapping: state\.parts\[1\] \(/joint_states\.name\): field is list, not numbers",
)
_parts_case(
    "mapping-part-empty-field",
    {"topic": "/joint_states", "field": "velocity", "names": ["v"]},
    r"log\.mcap: mapping: state\.parts\[1\] \(/joint_states\.velocity\): the field is empty",
)
