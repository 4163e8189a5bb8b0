"""`convert BAG --print-mapping`: a starting mapping for a bag nobody has described, its guesses marked.

Read from the bags' indexes (topics, types, rates) and from the first message of each JointState, Image and
CompressedImage topic of the first bag (joint names, image encodings), and of each topic of a type that is not
ROS's (an MCAP of another profile: Foxglove's schemas, JSON), the guesses are:

* state: the JointState topic (``position``, every joint its first message names), one named ``joint_states``
  first; without one, the first Float32/Float64MultiArray that is not a command; without one, the parts
  `guess_foreign` finds in every non-ROS topic that is not a command (Foxglove transforms, poses, fixes, JSON
  joint states and numbers);
* action: a command topic (a name with cmd/command/action/target/goal/desired, of a JointState, a MultiArray or a
  Twist, or a non-ROS topic with parts), else the state itself (marked: an action should be what was commanded);
* cameras: Image / foxglove.RawImage topics in an RGB encoding and (foxglove.)CompressedImage topics;
  depth_cameras: 16UC1/32FC1 Image / RawImage topics and compressedDepth topics; camera_info: each CameraInfo
  topic paired with the cameras in its namespace;
* task_topic: a String topic named like a task/instruction/language/prompt, else a placeholder task text;
  reward / success: Float32/Float64 ``reward`` and Bool ``success`` topics;
* fps: the slowest camera's or the action's mean rate, rounded (every frame needs a sample of each);
  align.max_staleness 1.5 frame periods.

The result always validates as a `Mapping`; `mapping_yaml` prints it with each guess's reason as a comment.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from openral_data.convert.camera_topics import COMPRESSED_TYPES, RAW_TYPES
from openral_data.convert.discover import BagInfo, describe_bags
from openral_data.convert.guess_foreign import foreign_parts
from openral_data.convert.sources import deserialize, open_reader, read_messages
from openral_data.errors import BagError
from openral_data.formats.mcap.messages import RGB_ENCODINGS
from openral_data.schemas.mapping import Mapping

_COMMAND = re.compile(r"cmd|command|action|target|goal|desired", re.IGNORECASE)
_TASK = re.compile(r"task|instruction|language|prompt", re.IGNORECASE)
_JOINTS = "sensor_msgs/msg/JointState"
_ARRAYS = ("std_msgs/msg/Float64MultiArray", "std_msgs/msg/Float32MultiArray")
_TWISTS = {"geometry_msgs/msg/Twist": "", "geometry_msgs/msg/TwistStamped": "twist."}
_DEPTH = ("16uc1", "32fc1")
# the last topic parts a camera name leaves out (/cam/image_raw -> cam)
_IMAGE_SUFFIXES = {"image_raw", "image", "compressed", "image_rect_raw", "image_rect", "image_color",
                   "image_rect_color", "compresseddepth", "color", "rgb", "depth_image"}  # fmt: skip


@dataclass
class Guess:
    """A mapping as plain data (what the YAML holds) and, per top-level key, why it was guessed so."""

    mapping: dict[str, Any]
    notes: dict[str, str] = field(default_factory=dict)

    def put(self, key: str, value: Any, note: str) -> None:
        self.mapping[key] = value
        self.notes[key] = note


def guess_mapping(src: Path) -> Guess:
    """The starting mapping for the bags of `src` (validated as a `Mapping` before it is returned)."""
    info = describe_bags(src)
    first = _first_messages(info.bags[0], info)
    guess = Guess({"fps": 10, "robot_type": "unknown"})
    state = _state(info, first, guess)
    action = _action(info, first, state, guess)
    _images(info, first, guess)
    _outcomes(info, guess)
    rates = [r for t in [action, *guess.mapping["cameras"].values(), *guess.mapping["depth_cameras"].values()]
             if (r := info.topics[t].rate)]  # fmt: skip
    fps = max(1, min(1000, round(min(rates)))) if rates else 10
    guess.mapping["fps"] = fps
    guess.notes["fps"] = "the slowest camera's or the action's mean rate, rounded (Hz)"
    guess.put("align", {"method": "previous", "max_staleness": round(1.5 / fps, 4)},
              "each stream's latest sample at most 1.5 frame periods old")  # fmt: skip
    try:
        Mapping.model_validate(guess.mapping)
    except ValueError as exc:  # pydantic's ValidationError
        raise BagError(f"{src}: the guessed mapping does not validate: {str(exc).splitlines()[0]}",
                       code="bag.invalid") from None  # fmt: skip
    return guess


def _first_messages(bag: Path, info: BagInfo) -> dict[str, Any]:
    """The first message of every JointState, Image and CompressedImage topic of `bag`, and of every topic of a
    type that is not ROS's (an MCAP of another profile: Foxglove's schemas, JSON)."""
    wanted = {_JOINTS, *RAW_TYPES, *COMPRESSED_TYPES}
    reader = open_reader(bag)
    out: dict[str, Any] = {}
    try:
        for conn in reader.connections:
            known = conn.msgtype in wanted or _foreign_type(conn.msgtype)
            if known and conn.topic in info.topics and conn.topic not in out:
                for c, _, raw in read_messages(reader, bag, [conn]):
                    out[conn.topic] = deserialize(reader, bag, raw, c.msgtype)
                    break
    finally:
        reader.close()
    return out


def _of(info: BagInfo, *types: str) -> list[str]:
    return [t.topic for t in info.topics.values() if t.msgtype in types]


def _foreign_type(msgtype: str) -> bool:
    """Not a ROS type (those are `pkg/msg/Type`): a Foxglove schema, a JSON or protobuf message."""
    return "/msg/" not in msgtype


def _foreign(info: BagInfo, first: dict[str, Any]) -> dict[str, list[dict[str, Any]]]:
    """Topic -> the vector parts of a topic of a non-ROS type (`guess_foreign`), for topics with 2+ messages."""
    out = {}
    for t in info.topics.values():
        if _foreign_type(t.msgtype) and t.messages >= 2 and t.topic in first:
            parts = foreign_parts(t.topic, t.msgtype, first[t.topic])
            if parts:
                out[t.topic] = parts
    return out


def _vector(parts: list[dict[str, Any]]) -> dict[str, Any]:
    return dict(parts[0]) if len(parts) == 1 else {"parts": parts}


def _state(info: BagInfo, first: dict[str, Any], guess: Guess) -> str:
    joints = [t for t in _of(info, _JOINTS) if not _COMMAND.search(t) and t in first]
    if joints:
        topic = sorted(joints, key=lambda t: (not t.endswith("joint_states"), t))[0]
        names = [str(n) for n in first[topic].name]
        value: dict[str, Any] = {"topic": topic, "field": "position", **({"joints": names} if names else {})}
        guess.put("state", value, f"{topic}: the position of every joint its first message names")
        return topic
    arrays = [t for t in _of(info, *_ARRAYS) if not _COMMAND.search(t)]
    foreign = {t: parts for t, parts in _foreign(info, first).items() if not _COMMAND.search(t)}
    if not arrays and foreign:
        parts = [p for topic_parts in foreign.values() for p in topic_parts]
        guess.put("state", _vector(parts), f"{', '.join(foreign)}: the numbers of every pose, transform or "
                  "numeric message that is not a command")  # fmt: skip
        return next(iter(foreign))
    if not arrays:
        raise BagError(f"{info.bags[0]}: no JointState, Float64MultiArray, Foxglove pose or transform, or numeric "
                       "JSON topic to guess a state from; write the mapping by hand (docs/convert.md)",
                       code="bag.topic")  # fmt: skip
    guess.put("state", {"topic": arrays[0], "field": "data"}, f"{arrays[0]}: no JointState topic; its data")
    return arrays[0]


def _action(info: BagInfo, first: dict[str, Any], state: str, guess: Guess) -> str:
    foreign = {t: parts for t, parts in _foreign(info, first).items() if t != state and _COMMAND.search(t)}
    numeric = [*_of(info, _JOINTS, *_ARRAYS, *_TWISTS)]
    commands = [t for t in numeric if t != state and _COMMAND.search(t)]
    if not commands and foreign:
        topic, parts = next(iter(foreign.items()))
        guess.put("action", _vector(parts), f"{topic}: a command topic (its numbers)")
        return topic
    if not commands:
        same = dict(guess.mapping["state"])
        guess.put("action", same, "no command topic found: the state itself; an action should be what was commanded")
        return state
    topic = commands[0]
    msgtype = info.topics[topic].msgtype
    if msgtype in _TWISTS:
        pre = _TWISTS[msgtype]
        parts = [{"topic": topic, "field": f"{pre}{v}.{a}", "names": [f"{v}.{a}"]}
                 for v in ("linear", "angular") for a in "xyz"]  # fmt: skip
        guess.put("action", {"parts": parts}, f"{topic}: a command topic (its linear and angular velocity)")
    elif msgtype == _JOINTS:
        value: dict[str, Any] = {"topic": topic, "field": "position"}
        guess.put("action", value, f"{topic}: a command topic (its position)")
    else:
        guess.put("action", {"topic": topic, "field": "data"}, f"{topic}: a command topic (its data)")
    return topic


def _camera_name(topic: str, used: set[str]) -> str:
    parts = [p for p in topic.strip("/").split("/") if p]
    kept = list(parts)
    while len(kept) > 1 and kept[-1].lower() in _IMAGE_SUFFIXES:
        kept.pop()
    for candidate in ("_".join(kept), "_".join(parts)):
        name = re.sub(r"[^A-Za-z0-9_]", "_", candidate) or "camera"
        if name not in used:
            return name
    n = 2
    while f"{name}_{n}" in used:
        n += 1
    return f"{name}_{n}"


def _images(info: BagInfo, first: dict[str, Any], guess: Guess) -> None:
    cameras: dict[str, str] = {}
    depth: dict[str, str] = {}
    used: set[str] = set()
    for topic in _of(info, *RAW_TYPES, *COMPRESSED_TYPES):
        msg = first.get(topic)
        if msg is None:
            continue
        if info.topics[topic].msgtype in COMPRESSED_TYPES:
            is_depth, is_rgb = "compresseddepth" in str(msg.format).lower(), True
        else:
            encoding = str(msg.encoding).lower()
            is_depth, is_rgb = encoding in _DEPTH, encoding in RGB_ENCODINGS
        if is_depth or is_rgb:
            name = _camera_name(topic, used)
            used.add(name)
            (depth if is_depth else cameras)[name] = topic
    guess.put("cameras", cameras, "Image / RawImage topics in an RGB encoding and CompressedImage topics")
    guess.put("depth_cameras", depth, "16UC1/32FC1 Image / RawImage topics and compressedDepth topics")
    infos = {}
    for info_topic in _of(info, "sensor_msgs/msg/CameraInfo"):
        namespace = info_topic.rsplit("/", 1)[0]
        for name, topic in {**cameras, **depth}.items():
            if topic.rsplit("/", 1)[0] == namespace:
                infos[name] = info_topic
    if infos:
        guess.put("camera_info", infos, "each CameraInfo topic paired with the cameras in its namespace")


def _outcomes(info: BagInfo, guess: Guess) -> None:
    tasks = [t for t in _of(info, "std_msgs/msg/String") if _TASK.search(t)]
    if tasks:
        guess.put("task_topic", tasks[0], f"{tasks[0]}: a String topic named like a task")
    else:
        guess.put("task", "describe the task here", "no task topic found: a fixed task text to fill in")
    rewards = [t for t in _of(info, "std_msgs/msg/Float64", "std_msgs/msg/Float32") if "reward" in t.lower()]
    if rewards:
        guess.put("reward", {"topic": rewards[0], "field": "data"}, f"{rewards[0]}: a number topic named reward")
    successes = [t for t in _of(info, "std_msgs/msg/Bool") if "success" in t.lower()]
    if successes:
        guess.put("success", {"topic": successes[0], "field": "data"}, f"{successes[0]}: a Bool named success")


def mapping_yaml(src: Path, guess: Guess) -> str:
    """The mapping as YAML, each top-level key after a ``# GUESS:`` comment saying why."""
    lines = [
        f"# A starting mapping for {src}, guessed by `openral-data convert SRC --print-mapping` from its topics.",
        "# Every GUESS is one: check it, edit, then `openral-data convert SRC DST --mapping this.yaml`.",
    ]
    for key, value in guess.mapping.items():
        note = guess.notes.get(key)
        if note:
            lines.append(f"# GUESS: {note}")
        lines.append(yaml.safe_dump({key: value}, sort_keys=False, default_flow_style=False, width=120).rstrip())
    return "\n".join(lines) + "\n"
