"""The vector parts `--print-mapping` (and a conversion of an MCAP of another profile without `--mapping`) guesses
from topics that are not ROS types: Foxglove's well-known schemas and joint-like JSON, read from each topic's
first message (a `Fields`, `formats.mcap.foreign`):

* ``foxglove.FrameTransform``: its translation (x, y, z) and rotation (qx, qy, qz, qw), named after its child frame;
  ``foxglove.FrameTransforms``: every transform of the first message, 7 numbers each, in that order;
* ``foxglove.PoseInFrame``: its pose (position, orientation: 7 numbers); ``foxglove.PosesInFrame``: every pose;
* ``foxglove.LocationFix``: latitude, longitude, altitude;
* a JSON message with ``name`` (strings) and ``position`` (numbers) of one length: a joint state (its joints by
  name, as a JointState's); else each top-level number or list of numbers of it.

A topic with fewer than two messages (a static transform) is no part: a frame needs a sample of each part at
most `align.max_staleness` old.
"""

from __future__ import annotations

import re
from typing import Any

from openral_data.formats.mcap.foreign import Fields

_POSE = ("x", "y", "z", "qx", "qy", "qz", "qw")


def _label(topic: str) -> str:
    return re.sub(r"[^A-Za-z0-9_]+", "_", topic.strip("/")) or "topic"


def foreign_parts(topic: str, msgtype: str, first: Any) -> list[dict[str, Any]]:
    """The vector parts a topic of type `msgtype` whose first message is `first` gives ([]: none)."""
    if not isinstance(first, Fields):
        return []
    label = _label(topic)
    if msgtype == "foxglove.FrameTransform":
        child = str(first.child_frame_id) or label
        return [
            {"topic": topic, "field": "translation", "names": [f"{child}.{a}" for a in _POSE[:3]]},
            {"topic": topic, "field": "rotation", "names": [f"{child}.{a}" for a in _POSE[3:]]},
        ]
    if msgtype == "foxglove.FrameTransforms":
        children = [str(t.child_frame_id) or f"{label}[{i}]" for i, t in enumerate(first.transforms)]
        names = [f"{c}.{a}" for c in children for a in _POSE]
        return [{"topic": topic, "field": "transforms", "names": names}] if names and _unique(names) else []
    if msgtype == "foxglove.PoseInFrame":
        return [{"topic": topic, "field": "pose", "names": [f"{label}.{a}" for a in _POSE]}]
    if msgtype == "foxglove.PosesInFrame":
        names = [f"{label}[{i}].{a}" for i in range(len(first.poses)) for a in _POSE]
        return [{"topic": topic, "field": "poses", "names": names}] if names else []
    if msgtype == "foxglove.LocationFix":
        return [{"topic": topic, "field": f, "names": [f"{label}.{f}"]} for f in ("latitude", "longitude", "altitude")]
    if msgtype.startswith("foxglove."):
        return []
    return _json_parts(topic, first)


def _json_parts(topic: str, first: Fields) -> list[dict[str, Any]]:
    names = getattr(first, "name", None)
    position = getattr(first, "position", None)
    if (
        isinstance(names, list)
        and names
        and all(isinstance(n, str) for n in names)
        and _unique(names)
        and isinstance(position, list)
        and _numeric(position)
        and len(position) == len(names)
    ):
        return [{"topic": topic, "field": "position", "joints": names}]
    return [{"topic": topic, "field": key} for key in first.field_names() if _numeric(getattr(first, key))]


def _numeric(value: Any) -> bool:
    """A number or a non-empty list of numbers (bools are flags, not numbers)."""
    items = value if isinstance(value, list) else [value]
    return bool(items) and all(isinstance(v, int | float) and not isinstance(v, bool) for v in items)


def _unique(names: list[str]) -> bool:
    return len(set(names)) == len(names)
