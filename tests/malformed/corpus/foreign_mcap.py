"""MCAP of other profiles than ROS 2 (Foxglove's, the `mcap` library's): cut short (a flipped chunk is refused by
the bounded walk every MCAP gets, as in `bags`), messages that do not decode (JSON, base64, protobuf), an encoding
nobody reads, images that lie about their size, a mapping naming a JSON field the messages lack. Each `convert`
with no mapping written (the guessed one) or with one."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

from tests.malformed.corpus.cases import case
from tests.support.foreign_mcap import IMAGE_SCHEMA, JOINTS_SCHEMA, write_foxglove
from tests.support.malformed import Workspace

_TS = {"sec": 1, "nsec": 0}


def _mcap(path: Path, channels: dict[str, tuple[str, str, dict[str, Any] | None]], messages: list[tuple[str, bytes]],
          ) -> Path:  # fmt: skip
    """An MCAP by the `mcap` library's Writer: channels topic -> (encoding, schema encoding, schema; its title the
    schema's name, else the topic); each message (topic, data) 0.1 s after the one before."""
    from mcap.writer import Writer

    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("wb") as f:
        w = Writer(f)
        w.start(profile="", library="malformed corpus")
        ids = {}
        for topic, (encoding, schema_encoding, schema) in channels.items():
            name = str((schema or {}).get("title", topic.strip("/")))
            sid = w.register_schema(name, schema_encoding, json.dumps(schema or {}).encode())
            ids[topic] = w.register_channel(topic, encoding, sid)
        for i, (topic, data) in enumerate(messages):
            w.add_message(ids[topic], log_time=1_000_000_000 + i * 100_000_000, data=data, publish_time=0)
        w.finish()
    return path


def _joints(n: int = 6) -> list[tuple[str, bytes]]:
    msg = {"timestamp": _TS, "name": ["a"], "position": [1.0]}
    return [("/joints", json.dumps(msg).encode())] * n


_Channels = dict[str, tuple[str, str, dict[str, Any] | None]]
_JOINTS: _Channels = {"/joints": ("json", "jsonschema", JOINTS_SCHEMA)}
_CAMERA: _Channels = {**_JOINTS, "/camera": ("json", "jsonschema", IMAGE_SCHEMA)}


def _with_camera(data: str) -> list[tuple[str, bytes]]:
    image = json.dumps({"timestamp": _TS, "frame_id": "c", "format": "png", "data": data}).encode()
    return [m for j in _joints() for m in (j, ("/camera", image))]


def _foreign_case(id: str, make: Callable[[Workspace], Path], names: str, mapping: dict[str, Any] | None = None,
                  ) -> None:  # fmt: skip
    def build(w: Workspace) -> list[str]:
        src = make(w)
        extra = ["--mapping", str(w.yaml("m.yaml", mapping))] if mapping else []
        return ["convert", str(src), str(w.root / "o"), "--codec", "h264", *extra]

    case(id, build, names, ("o",))


def _cut(w: Workspace, keep: float) -> Path:
    data = write_foxglove(w.path("src/fox.mcap")).read_bytes()
    return w.write("cut.mcap", data[: int(len(data) * keep)])


# mcap's reader (not rosbags, which refused every profile but ros2 wholesale) says what is wrong
_READ = r"\.mcap: cannot read bag: (?!Profile is not ros2)\w"
_foreign_case("foreign-mcap-truncated-50", lambda w: _cut(w, 0.5), r"cut" + _READ)
_foreign_case("foreign-mcap-truncated-95", lambda w: _cut(w, 0.95), r"cut" + _READ)
_foreign_case(
    "foreign-mcap-json-not-json",
    lambda w: _mcap(w.path("j.mcap"), _JOINTS, [*_joints(), ("/joints", b"{not json")]),
    r"j\.mcap: a joints message does not decode",
)
_foreign_case(
    "foreign-mcap-json-bad-base64",
    lambda w: _mcap(w.path("j.mcap"), _CAMERA, _with_camera("!!not base64!!")),
    r"j\.mcap: a foxglove\.CompressedImage message does not decode: a base64 field",
)
_foreign_case(
    "foreign-mcap-image-not-an-image",
    lambda w: _mcap(w.path("j.mcap"), _CAMERA, _with_camera("bm90IGFuIGltYWdl")),
    r"j\.mcap: .*/camera.*does not decode as an image",
)
_foreign_case(
    "foreign-mcap-protobuf-garbage",
    lambda w: _mcap(
        w.path("p.mcap"), {"/p": ("protobuf", "protobuf", None)}, [("/p", b"\xff\xff\xff")] * 3
    ),  # a schema that is no FileDescriptorSet
    r"p\.mcap: /p: the protobuf schema of p does not load",
)
_foreign_case(
    "foreign-mcap-unknown-encoding",
    lambda w: _mcap(w.path("f.mcap"), {"/f": ("flatbuffer", "flatbuffer", None)}, [("/f", b"x")] * 3),
    r"f\.mcap: /f: message encoding 'flatbuffer' is not read",
    {"fps": 10, "task": "t", "state": {"topic": "/f", "field": "x"}, "action": {"topic": "/f", "field": "x"}},
)
_foreign_case(
    "foreign-mcap-json-missing-field",
    lambda w: _mcap(w.path("j.mcap"), _JOINTS, _joints()),
    r"j\.mcap: mapping: state \(/joints\.velocity\): message has no field 'velocity' \(fields here: timestamp, name, "
    r"position\)",
    {"fps": 10, "task": "t", "state": {"topic": "/joints", "field": "velocity"}, "action": {"topic": "/joints"}},
)


def _raw_image_short(w: Workspace) -> Path:
    """A foxglove.RawImage (JSON) that says 100000x100000 and holds 3 bytes."""
    schema = {"title": "foxglove.RawImage", "properties": {"data": {"contentEncoding": "base64"}}}
    raw = {"width": 100000, "height": 100000, "encoding": "rgb8", "step": 300000, "data": "AAAA"}
    messages = [m for j in _joints() for m in (j, ("/raw", json.dumps(raw).encode()))]
    return _mcap(w.path("r.mcap"), {**_JOINTS, "/raw": ("json", "jsonschema", schema)}, messages)


_foreign_case(
    "foreign-mcap-raw-image-short",
    _raw_image_short,
    r"r\.mcap: .*/raw.*100000x100000 rgb8 image with step 300000 has 3 bytes",
    {"fps": 10, "task": "t", "state": {"topic": "/joints"}, "action": {"topic": "/joints"}, "cameras": {"raw": "/raw"}},
)
