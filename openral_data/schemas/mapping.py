"""`convert --mapping mapping.yaml`: which bag topics and fields become which LeRobot v3 features.

```yaml
fps: 20                       # target frame rate of the dataset
robot_type: my_arm            # optional
task: pick up the cube        # a fixed task text, or
# task_topic: /task           # a std_msgs/String topic (its latest value at each frame)
state:                        # -> observation.state
  topic: /joint_states
  field: position             # a field path of the message (dots for nesting)
  joints: [j1, j2, j3]        # JointState: pick these names in this order
action:                       # -> action
  topic: /cmd
  field: data
  names: [x, y, z]            # names of the dims (default: joints, or <topic>.<field>[i])
# state / action may instead be `parts`: several sources concatenated in this order, each aligned on its own
# (a frame is fillable only if every part is), each with its own names (default as above, per part):
# state:
#   parts:
#     - {topic: /arm/joint_states, field: position, joints: [j1, j2, j3]}
#     - {topic: /gripper/joint_states, field: position, names: [finger]}
environment_state:            # optional -> observation.environment_state (non-robot state such as object
  topic: /object/pose         #   poses), in the form of state / action (one source or `parts`); aligned
  field: data                 #   like state (a frame is fillable only if it is). Without it: no such column.
  names: [x, y, z]
# Roles may share a topic (state = position, action = velocity of one JointState; reward and success other
# fields of it): each reads its own field of the same messages. A camera topic is only a camera.
# Array sources (HDF5, zarr, RLDS; topic = an array key) also take `offset: N` on state / action /
# environment_state or a part: step t reads the array's step t + N, the episode's last step once past it
# (action: {topic: data/state, offset: 1} = the next step's state). Bags align by time and refuse it.
cameras:                      # camera name -> sensor_msgs Image or CompressedImage topic
  front: /camera/front/image/compressed
image_origin: top             # top | bottom: the cameras' pictures are stored bottom row first (robosuite renders
                              #   read back from OpenGL, as LIBERO stores them): written upright (flipped
                              #   vertically). Colour cameras only.
depth_cameras:                # camera name -> sensor_msgs Image topic in 16UC1 (millimetres) or 32FC1 (metres),
                              #   or a CompressedImage in image_transport's compressedDepth png
  front_depth: /camera/depth/image_rect_raw   # -> observation.images.front_depth, a lerobot depth video
depth:                        # optional: lerobot's DepthEncoderConfig quantizer (these are its defaults): depth
  depth_min: 0.01             #   in metres is mapped to 12-bit codes, log-spaced (use_log) or linear between
  depth_max: 10.0             #   depth_min and depth_max; pixels outside (a 16UC1 0, a 32FC1 NaN/inf) load as
  shift: 3.5                  #   depth_min or depth_max
  use_log: true
camera_info:                  # optional: camera name (colour or depth) -> sensor_msgs CameraInfo topic; its first
  front_depth: /camera/depth/camera_info   # message's intrinsics go in the feature's info.camera_info
reward:                       # optional -> next.reward; aligned like state (a missing reward makes the
  topic: /reward              #   frame unfillable). Without it the dataset has no next.reward column.
  field: data
success:                      # optional -> next.success and the episode's success. Without it the dataset
  topic: /task_success        #   has no next.success column and every episode's success is unknown (NULL).
  field: data                 # a bool field: a frame's next.success is the latest value at the frame time
                              #   in its source episode (false before the first; episode: NULL if none)
  marker: false               # true: episode success from `{"event": "end", "success": ...}` markers on
                              #   episodes.marker_topic (as openral-data bags carry)
columns:                      # optional: extra per-frame features, each aligned like state (as openral-data
  openral.intervention:       #   bags carry an intervention session's; `convert` maps those by itself)
    topic: /openral/intervention
    field: data
    dtype: bool               # bool (a flag, shape [1]) | float32 (a vector, one name per dimension in `names`)
                              # openral.* names are ours: only openral.intervention (bool) and openral.policy_action
                              #   (float32, the action's dimension); none of lerobot's features, nor `task`
align:
  method: previous            # previous | nearest sample
  max_staleness: 0.1          # seconds; frames with a stream older than this cannot be filled
  clock: log                  # log (bag receive time) | header (header.stamp where the message has one)
  reorder: 0.5                # clock: header: seconds a message's stamp may lag behind the newest stamp read
episodes:
  split: bag                  # bag (one per bag file) | marker (messages on marker_topic) | gap
  marker_topic: /openral/episode
  gap: 1.0                    # seconds without any mapped message that start a new episode
```
Episode ends always give next.done (true on the last frame of every episode).
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Literal

from pydantic import Field, model_validator

from openral_data.columns import FRAME_COLUMNS
from openral_data.schemas.base import StrictModel, load_model

_FIELD = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*(\.[A-Za-z_][A-Za-z0-9_]*)*$")
_CAMERA = re.compile(r"^[A-Za-z0-9_]+$")


def _check_names(field: str, joints: list[str] | None, names: list[str] | None) -> None:
    if not _FIELD.match(field):
        raise ValueError(f"field {field!r} is not a dotted field path")
    for key, values in (("joints", joints), ("names", names)):
        if values is not None and (not values or len(set(values)) != len(values)):
            raise ValueError(f"{key} must be a non-empty list of unique names")
    if joints is not None and names is not None and len(joints) != len(names):
        raise ValueError(f"names has {len(names)} entries but joints has {len(joints)}")


class VectorSource(StrictModel):
    """A float vector read from one field of the messages on one topic (one part of a state or action)."""

    topic: str = Field(min_length=1)
    field: str = "position"
    joints: list[str] | None = None
    names: list[str] | None = None
    offset: int = Field(default=0, ge=0, le=100_000)  # array sources: step t reads step t + offset

    @model_validator(mode="after")
    def _check(self) -> VectorSource:
        _check_names(self.field, self.joints, self.names)
        return self

    def fixed_names(self) -> list[str] | None:
        """The dimension names the mapping fixes (names, else joints); None: named after the topic and field."""
        return self.names if self.names is not None else self.joints


class Vector(StrictModel):
    """state / action / environment_state: one source (`topic`, `field`, `joints`, `names`), or `parts`: several
    sources whose vectors are concatenated in the listed order (each aligned on its own)."""

    topic: str | None = Field(default=None, min_length=1)
    field: str | None = None  # the single-source form's field; default "position"
    joints: list[str] | None = None
    names: list[str] | None = None
    offset: int | None = Field(default=None, ge=0, le=100_000)  # the single-source form's offset; default 0
    parts: list[VectorSource] | None = None

    @model_validator(mode="after")
    def _check(self) -> Vector:
        if self.parts is None:
            if self.topic is None:
                raise ValueError("needs topic (one source) or parts (several, concatenated in order)")
            _check_names(self.field or "position", self.joints, self.names)
            return self
        beside = [k for k in ("topic", "field", "joints", "names", "offset") if getattr(self, k) is not None]
        if beside:
            raise ValueError(
                f"{', '.join(beside)} beside parts: give each part its own topic, field, joints, names, offset"
            )
        if not self.parts:
            raise ValueError("parts must be a non-empty list")
        seen: dict[str, int] = {}
        for i, part in enumerate(self.parts):
            # a part without names is named <topic>.<field>[k]: two such parts of one topic and field collide
            for name in part.fixed_names() or [f"{part.topic}.{part.field}"]:
                if name in seen:
                    raise ValueError(
                        f"parts[{seen[name]}] and parts[{i}] both name a dimension {name!r} (give each part "
                        "its own names)"
                    )
                seen[name] = i
        return self

    def sources(self) -> list[VectorSource]:
        """The parts in order (one for the single-source form)."""
        if self.parts is not None:
            return list(self.parts)
        assert self.topic is not None
        field = self.field or "position"
        return [
            VectorSource(topic=self.topic, field=field, joints=self.joints, names=self.names, offset=self.offset or 0)
        ]

    def labels(self) -> list[str]:
        """Where each part is in the mapping, for messages: `parts[i]`, or "" for the single-source form."""
        return [f"parts[{i}]" for i in range(len(self.parts))] if self.parts is not None else [""]


class ScalarSource(StrictModel):
    """One number (or bool) read from one field of the messages on one topic."""

    topic: str = Field(min_length=1)
    field: str = "data"

    @model_validator(mode="after")
    def _check_field(self) -> ScalarSource:
        if not _FIELD.match(self.field):
            raise ValueError(f"field {self.field!r} is not a dotted field path")
        return self


class SuccessSource(StrictModel):
    """Where success comes from: a topic with a bool field (per frame), end markers (per episode), or both."""

    topic: str | None = Field(default=None, min_length=1)
    field: str = "data"
    marker: bool = False

    @model_validator(mode="after")
    def _check(self) -> SuccessSource:
        if self.topic is None and not self.marker:
            raise ValueError("success needs a topic, marker: true, or both")
        if not _FIELD.match(self.field):
            raise ValueError(f"field {self.field!r} is not a dotted field path")
        return self


class ColumnSource(StrictModel):
    """An extra per-frame feature read from one field of one topic: a float32 vector (`names`: one per dimension,
    default `<topic>.<field>[i]`) or a bool flag (a Bool's `data`; stored with shape [1], no names)."""

    topic: str = Field(min_length=1)
    field: str = "data"
    dtype: Literal["float32", "bool"] = "float32"
    names: list[str] | None = None

    @model_validator(mode="after")
    def _check(self) -> ColumnSource:
        _check_names(self.field, None, self.names)
        if self.dtype == "bool" and self.names is not None:
            raise ValueError("a bool column has no names (it is one flag)")
        return self

    def vector_source(self) -> VectorSource:
        """The column read as a vector (a bool as one number), by the readers of state and action."""
        return VectorSource(topic=self.topic, field=self.field, names=self.names)


# features a column cannot be: the ones every dataset has, the mapping's roles fill or lerobot's loader adds
# (`task`), and the cameras' (tests/convert/test_mapping_columns.py keeps it in step with formats/lerobot_v3)
_RESERVED = {"observation.state", "observation.environment_state", "action", "timestamp", "frame_index"}
_RESERVED |= {"episode_index", "index", "task_index", "task", "next.reward", "next.done", "next.success"}
_RESERVED |= {"observation.images"}
_COLUMN = re.compile(r"^[A-Za-z0-9_]+(\.[A-Za-z0-9_]+)*$")


def column_problem(key: str, dtype: str) -> str | None:
    """Why `key` (with `dtype`) cannot be an extra per-frame column, or None."""
    if not _COLUMN.match(key) or key in _RESERVED or key.startswith("observation.images."):
        return f"{key!r} is not a free feature name (dotted words, none of lerobot's own)"
    if key.startswith("openral.") and key not in FRAME_COLUMNS:
        return f"{key!r}: openral.* names are openral-data's own (only {', '.join(FRAME_COLUMNS)} are columns)"
    if key in FRAME_COLUMNS and dtype != FRAME_COLUMNS[key]:
        return f"{key!r} is a {FRAME_COLUMNS[key]} column (dtype: {FRAME_COLUMNS[key]})"
    return None


class DepthQuantization(StrictModel):
    """lerobot 0.6.1's `DepthEncoderConfig` quantizer settings (metres)."""

    depth_min: float = Field(default=0.01, ge=0, allow_inf_nan=False)
    depth_max: float = Field(default=10.0, gt=0, allow_inf_nan=False)
    shift: float = Field(default=3.5, allow_inf_nan=False)
    use_log: bool = True

    @model_validator(mode="after")
    def _check(self) -> DepthQuantization:
        if self.depth_max <= self.depth_min:
            raise ValueError(f"depth_max ({self.depth_max}) must be above depth_min ({self.depth_min})")
        if self.use_log and self.depth_min + self.shift <= 0:
            raise ValueError("use_log needs depth_min + shift > 0")
        return self


class Align(StrictModel):
    method: Literal["previous", "nearest"] = "previous"
    max_staleness: float = Field(default=0.1, gt=0)
    clock: Literal["log", "header"] = "log"
    reorder: float = Field(default=0.5, ge=0)


class Episodes(StrictModel):
    split: Literal["bag", "marker", "gap"] = "bag"
    marker_topic: str | None = None
    gap: float | None = Field(default=None, gt=0)

    @model_validator(mode="after")
    def _check(self) -> Episodes:
        if self.split == "marker" and not self.marker_topic:
            raise ValueError("split: marker needs marker_topic")
        if self.split == "gap" and self.gap is None:
            raise ValueError("split: gap needs gap (seconds)")
        return self


class Mapping(StrictModel):
    fps: int = Field(gt=0, le=1000)
    robot_type: str = "unknown"
    task: str | None = Field(default=None, min_length=1)
    task_topic: str | None = None
    state: Vector
    action: Vector
    environment_state: Vector | None = None
    cameras: dict[str, str] = Field(default_factory=dict)
    image_origin: Literal["top", "bottom"] = "top"
    depth_cameras: dict[str, str] = Field(default_factory=dict)
    depth: DepthQuantization = Field(default_factory=DepthQuantization)
    camera_info: dict[str, str] = Field(default_factory=dict)
    reward: ScalarSource | None = None
    success: SuccessSource | None = None
    columns: dict[str, ColumnSource] = Field(default_factory=dict)
    align: Align = Field(default_factory=Align)
    episodes: Episodes = Field(default_factory=Episodes)

    @model_validator(mode="after")
    def _check(self) -> Mapping:
        if (self.task is None) == (self.task_topic is None):
            raise ValueError("set exactly one of task (a fixed text) or task_topic")
        for name in [*self.cameras, *self.depth_cameras]:
            if not _CAMERA.match(name):
                raise ValueError(f"camera name {name!r}: letters, digits and _ only")
            if name in self.cameras and name in self.depth_cameras:
                raise ValueError(f"camera name {name!r} is in both cameras and depth_cameras")
        for key, column in self.columns.items():
            problem = column_problem(key, column.dtype)
            if problem is not None:
                raise ValueError(f"columns: {problem}")
            if column.topic in (self.task_topic, self.episodes.marker_topic):
                raise ValueError(f"columns: {key!r}: topic {column.topic} is the task_topic or the marker_topic")
        topics = self.topics()
        images = self.image_topics()
        if len(set(images.values())) != len(images):
            raise ValueError("two cameras map the same topic")
        cameras = set(images.values())
        for name, info_topic in self.camera_info.items():
            if name not in images:
                raise ValueError(f"camera_info.{name}: no camera or depth camera of that name")
            if info_topic in topics:
                raise ValueError(f"camera_info.{name}: {info_topic} is also mapped as data")
        for key, topic in (
            ("reward topic", self.reward.topic if self.reward is not None else None),
            ("success.topic", self.success_topic),
            *((f"columns.{key} topic", c.topic) for key, c in self.columns.items()),
        ):
            if topic is not None and topic in cameras:
                raise ValueError(f"{key} {topic} is also mapped as a camera")
        if self.task_topic is not None and self.task_topic in topics:
            raise ValueError(f"task_topic {self.task_topic} is also mapped as data")
        if self.success_topic is not None and self.success_topic == self.task_topic:
            raise ValueError(f"success.topic {self.success_topic} is also the task_topic")
        if self.success_topic is not None and self.success_topic == self.episodes.marker_topic:
            raise ValueError(f"success.topic {self.success_topic} is the marker_topic; use success: {{marker: true}}")
        if self.success is not None and self.success.marker and not self.episodes.marker_topic:
            raise ValueError("success: marker: true needs episodes.marker_topic")
        return self

    @property
    def success_topic(self) -> str | None:
        return self.success.topic if self.success is not None else None

    def vectors(self) -> list[tuple[str, Vector]]:
        """(role, vector) for `state`, `action` and, when mapped, `environment_state`, in that order."""
        roles = [("state", self.state), ("action", self.action)]
        return roles + ([("environment_state", self.environment_state)] if self.environment_state else [])

    def vector_sources(self) -> list[tuple[str, VectorSource]]:
        """(role, part) for every part of every vector role (`vectors`), in order."""
        return [(role, s) for role, v in self.vectors() for s in v.sources()]

    def image_topics(self) -> dict[str, str]:
        """camera name -> topic, colour cameras then depth cameras."""
        return {**self.cameras, **self.depth_cameras}

    def topics(self) -> list[str]:
        """The aligned topics: every frame takes one sample of each. Roles may share a topic (state = position,
        action = velocity of one JointState topic): each reads its own field of the same messages."""
        reward = [self.reward.topic] if self.reward is not None else []
        vectors = [s.topic for _, s in self.vector_sources()]
        columns = [c.topic for c in self.columns.values()]
        return list(dict.fromkeys([*vectors, *self.image_topics().values(), *reward, *columns]))


def load_mapping(path: Path) -> Mapping:
    return load_model(Mapping, path)
