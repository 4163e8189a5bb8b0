"""The mapping `convert` uses without `--mapping` for bags that openral-data wrote itself (`record --format
mcap` or `convert DATASET DST`): everything is described by the `/openral/episode` start marker (an intervention
session's per-frame columns too: its `frame_columns`)."""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

from pydantic import ValidationError

from openral_data.convert.sources import BAG_READ_ERRORS, deserialize, open_reader, read_messages
from openral_data.errors import BagError
from openral_data.formats.jsonfile import parse_json
from openral_data.formats.mcap import messages as m
from openral_data.schemas.base import format_validation_error
from openral_data.schemas.mapping import Mapping


def own_mapping(bag: Path) -> Mapping:
    """The mapping `bag`'s start marker describes."""
    return _mapping(bag, *_read_start(bag))


def _mapping(bag: Path, start: dict[str, Any] | None, topics: set[str]) -> Mapping:
    if start is None:
        raise BagError(f"{bag}: {m.EPISODE} has no start marker; pass --mapping mapping.yaml", code="bag.invalid")
    try:
        return _from_start(bag, start, topics)
    except ValidationError as exc:  # the field named: frame_columns are the mapping's columns
        text = format_validation_error(f"{bag}: {m.EPISODE} start marker", exc).replace(": <root>: ", ": ")
        raise BagError(re.sub(r"(: |; )columns\b", r"\1frame_columns", text), code="bag.invalid") from None
    except (KeyError, TypeError, ValueError, ZeroDivisionError) as exc:
        reason = f"missing {exc}" if isinstance(exc, KeyError) else str(exc).splitlines()[0]
        raise BagError(f"{bag}: {m.EPISODE} start marker: {reason}", code="bag.invalid") from None


def own_bags_mapping(bags: list[Path]) -> Mapping:
    """The mapping of a folder of our own bags: the first bag's. Every bag must carry the same per-frame columns
    (`frame_columns`): a bag without them has no value for its frames, and a first bag without them would drop
    the others' (the other fields' topics are checked by `preflight.check_bags`). Reads each bag's markers up to
    its start marker (the first one written)."""
    first, topics = _read_start(bags[0])
    mapping = _mapping(bags[0], first, topics)
    assert first is not None
    for bag in bags[1:]:
        start, _ = _read_start(bag)
        if ((start or {}).get("frame_columns") or {}) != (first.get("frame_columns") or {}):
            raise BagError(f"{bag}: {m.EPISODE} start marker: frame_columns: differ from {bags[0]}'s",
                           code="bag.invalid")  # fmt: skip
    return mapping


def _read_start(bag: Path) -> tuple[dict[str, Any] | None, set[str]]:
    """`bag`'s start marker (None: it has none) and its topics."""
    reader = open_reader(bag)
    try:
        topics = {c.topic: c for c in reader.connections}
        marker = topics.get(m.EPISODE)
        if marker is None:
            raise BagError(
                f"{bag}: not written by openral-data (no {m.EPISODE} topic); pass --mapping mapping.yaml "
                f"(`openral-data convert {bag} --print-mapping` prints a starting one)",
                code="bag.invalid",
            )
        for conn, _, raw in read_messages(reader, bag, [marker]):
            event = parse_json(deserialize(reader, bag, raw, conn.msgtype).data)
            if isinstance(event, dict) and event.get("event") == "start":
                return event, set(topics)
    except (*BAG_READ_ERRORS, AttributeError) as exc:
        raise BagError(f"{bag}: cannot read bag: {exc}", code="bag.invalid") from None
    finally:
        reader.close()
    return None, set(topics)


def _from_start(bag: Path, start: dict[str, Any], topics: set[str]) -> Mapping:
    cameras = {}
    for name in start["cameras"]:
        found = [t for t in (m.camera_topic(name, "jpeg"), m.camera_topic(name, "raw")) if t in topics]
        if not found:
            raise BagError(f"{bag}: no image topic for camera {name!r}", code="bag.topic")
        cameras[name] = found[0]
    depth = start.get("depth_cameras") or {}
    if not isinstance(depth, dict):
        raise TypeError("depth_cameras: not a mapping of camera name -> quantizer settings")
    for name in depth:
        if m.depth_topic(name) not in topics:
            raise BagError(f"{bag}: no depth topic for depth camera {name!r}", code="bag.topic")
    infos = {name: m.camera_info_topic(name) for name in [*cameras, *depth] if m.camera_info_topic(name) in topics}
    # bags written before the start marker said which outcomes are known always carried reward and success
    outcomes = start.get("outcomes") or {"reward": True, "success": True}
    has_reward = bool(outcomes.get("reward")) and m.REWARD in topics
    fps = int(start["fps"])
    # bags written before the start marker named it, or of a source without one, have no environment state
    env_names = start.get("environment_state_names") or None
    # an intervention session's per-frame columns (bags written before they were kept, or plain ones, have none)
    columns = start.get("frame_columns") or {}
    if not isinstance(columns, dict):
        raise TypeError("frame_columns: not a mapping of feature key -> topic, dtype, names")
    for key, column in columns.items():
        if column["topic"] not in topics:
            raise BagError(f"{bag}: no topic {column['topic']} for the per-frame column {key!r}", code="bag.topic")
    return Mapping.model_validate(
        {
            "fps": fps,
            "robot_type": start.get("robot_type") or "unknown",
            "task_topic": m.TASK,
            "state": {"topic": m.JOINT_STATES, "field": "position", "joints": start["state_names"]},
            "action": {"topic": m.ACTION, "field": "data", "names": start["action_names"]},
            "environment_state": {"topic": m.ENVIRONMENT_STATE, "field": "data", "names": env_names}
            if env_names
            else None,
            "cameras": cameras,
            "depth_cameras": {name: m.depth_topic(name) for name in depth},
            # one quantizer for all depth cameras, as in lerobot: the first one's
            "depth": next(iter(depth.values()), None) or {},
            "camera_info": infos,
            "reward": {"topic": m.REWARD, "field": "data"} if has_reward else None,
            "success": {"marker": True} if outcomes.get("success") else None,
            "columns": {
                key: {"topic": c["topic"], "dtype": c["dtype"], "names": c.get("names") or None}
                for key, c in columns.items()
            },
            # every stream is stamped on the same grid: the exact sample, never a neighbour's
            "align": {"method": "nearest", "max_staleness": 0.25 / fps},
            "episodes": {"split": "marker", "marker_topic": m.EPISODE},
        }
    )
