"""ROS 2 messages the MCAP sink writes: standard types from rosbags' typestore, serialised as CDR.

Topics of one episode bag (names are stable; `convert` and `export` rely on them):

* ``/joint_states``   ``sensor_msgs/msg/JointState``: ``name`` = the state contract's names, ``position`` =
  ``observation.state`` (float32 widened to float64, exact).
* ``/action``         ``std_msgs/msg/Float32MultiArray``: the action vector, float32 as recorded (see docs/convert.md).
* ``/camera/<name>/image/compressed`` ``sensor_msgs/msg/CompressedImage`` (format ``jpeg`` or ``png``), or
  ``/camera/<name>/image_raw`` ``sensor_msgs/msg/Image`` (``rgb8``) with ``image_format: raw``.
* ``/camera/<name>/depth/image_raw`` ``sensor_msgs/msg/Image`` of a depth camera: ``16UC1`` millimetres or
  ``32FC1`` metres, the unit its frames came in (a simulated depth camera: 32FC1).
* ``/camera/<name>/segmentation/image_raw`` ``sensor_msgs/msg/Image`` of a segmentation mask: ``mono16``, each
  pixel the uint16 object id (0 = background; the names in the start marker's ``segmentation_cameras``).
* ``/camera/<name>/camera_info`` ``sensor_msgs/msg/CameraInfo``, once at the start, for a camera whose feature
  info has ``camera_info``; ``/tf_static`` ``tf2_msgs/msg/TFMessage``, once at the start: the pose of every camera
  whose info has ``extrinsics`` (its optical frame ``<name>`` in its ``parent_frame``).
* ``/tf``             ``tf2_msgs/msg/TFMessage``, per frame, when the producer reports where the bodies cameras
  are mounted on are (``Frame.transforms``: a wrist camera's body): each such body in ``world``, so the camera's
  world pose is that transform composed with its ``/tf_static`` one.
* ``/reward``         ``std_msgs/msg/Float32``: the reward that followed the action of the same stamp (absent
  when the source has no reward).
* ``/task``           ``std_msgs/msg/String``: the task text, published on the first frame and on change.
* ``/openral/policy_action`` ``std_msgs/msg/Float32MultiArray`` and ``/openral/intervention`` ``std_msgs/msg/Bool``,
  per frame, only in a recording that has them (an intervention session): the schema's `frame_columns`, each on
  `column_topic(key)` (a float32 vector as the action is written, a flag as a Bool); the start marker's
  ``frame_columns`` lists them (key -> topic, dtype, names).
* ``/openral/episode`` ``std_msgs/msg/String``: JSON ``{"event": "start"|"end", ...}`` markers; the end
  marker carries ``success`` (``null``: unknown), ``length`` and, when the recording said who drove and how
  (the dataset's ``openral.episode_info``), ``info``; the start marker's ``outcomes`` says whether reward and
  success are known.
"""

from __future__ import annotations

import io
import json
from typing import Any, Literal

import numpy as np
import numpy.typing as npt
from PIL import Image as PILImage
from rosbags.typesys import Stores, get_typestore
from rosbags.typesys.store import Typestore

from openral_data.errors import UsageError

ImageFormat = Literal["jpeg", "png", "raw"]
IMAGE_FORMATS: tuple[ImageFormat, ...] = ("jpeg", "png", "raw")


def parse_image_format(name: str) -> ImageFormat:
    """`--image-format` (or any untyped text) -> an `ImageFormat`; below the edge the value is never checked again."""
    if name not in IMAGE_FORMATS:
        raise UsageError(f"--image-format: {name!r} is not one of {', '.join(IMAGE_FORMATS)}")
    return name


JOINT_STATES = "/joint_states"
ACTION = "/action"
ENVIRONMENT_STATE = "/environment_state"  # lerobot's observation.environment_state, when the source has one
REWARD = "/reward"
TASK = "/task"
EPISODE = "/openral/episode"

JOINT_STATE_T = "sensor_msgs/msg/JointState"
COMPRESSED_T = "sensor_msgs/msg/CompressedImage"
IMAGE_T = "sensor_msgs/msg/Image"
CAMERA_INFO_T = "sensor_msgs/msg/CameraInfo"
TF_T = "tf2_msgs/msg/TFMessage"
TF_STATIC = "/tf_static"
TF = "/tf"
FLOAT32_ARRAY_T = "std_msgs/msg/Float32MultiArray"
FLOAT32_T = "std_msgs/msg/Float32"
BOOL_T = "std_msgs/msg/Bool"
STRING_T = "std_msgs/msg/String"

_STORE: Typestore | None = None


def typestore() -> Typestore:
    """The ROS 2 typestore (Humble definitions: the message hashes every current distro shares)."""
    global _STORE  # noqa: PLW0603 - built once, immutable afterwards
    if _STORE is None:
        _STORE = get_typestore(Stores.ROS2_HUMBLE)
    return _STORE


def camera_topic(name: str, fmt: ImageFormat) -> str:
    return f"/camera/{name}/image_raw" if fmt == "raw" else f"/camera/{name}/image/compressed"


def depth_topic(name: str) -> str:
    """A depth camera's topic: 16UC1 millimetres, whatever the colour cameras' image format."""
    return f"/camera/{name}/depth/image_raw"


def segmentation_topic(name: str) -> str:
    """A segmentation mask's topic: mono16 object ids."""
    return f"/camera/{name}/segmentation/image_raw"


def camera_info_topic(name: str) -> str:
    return f"/camera/{name}/camera_info"


def column_topic(key: str) -> str:
    """A per-frame column's topic: its key with dots as slashes (`openral.intervention` -> /openral/intervention)."""
    return "/" + key.replace(".", "/")


def camera_type(fmt: ImageFormat) -> str:
    return IMAGE_T if fmt == "raw" else COMPRESSED_T


class MessageFactory:
    """Builds and serialises the messages of one recording; `stamp_ns` is nanoseconds since the epoch."""

    def __init__(self, image_format: ImageFormat = "jpeg", jpeg_quality: int = 90) -> None:
        self.store = typestore()
        self.image_format: ImageFormat = image_format
        self.jpeg_quality = jpeg_quality
        t = self.store.types
        self._time = t["builtin_interfaces/msg/Time"]
        self._header = t["std_msgs/msg/Header"]
        self._joint_state = t[JOINT_STATE_T]
        self._compressed = t[COMPRESSED_T]
        self._image = t[IMAGE_T]
        self._camera_info = t[CAMERA_INFO_T]
        self._tf = t[TF_T]
        self._transform_stamped = t["geometry_msgs/msg/TransformStamped"]
        self._transform = t["geometry_msgs/msg/Transform"]
        self._vector3 = t["geometry_msgs/msg/Vector3"]
        self._quaternion = t["geometry_msgs/msg/Quaternion"]
        self._roi = t["sensor_msgs/msg/RegionOfInterest"]
        self._f32_array = t[FLOAT32_ARRAY_T]
        self._layout = t["std_msgs/msg/MultiArrayLayout"]
        self._dim = t["std_msgs/msg/MultiArrayDimension"]
        self._f32 = t[FLOAT32_T]
        self._bool = t[BOOL_T]
        self._string = t[STRING_T]
        self._empty_f64: npt.NDArray[np.float64] = np.zeros(0, dtype=np.float64)

    def _stamp_header(self, stamp_ns: int, frame_id: str = "") -> Any:
        sec, nanosec = divmod(stamp_ns, 1_000_000_000)
        return self._header(stamp=self._time(sec=sec, nanosec=nanosec), frame_id=frame_id)

    def joint_state(self, stamp_ns: int, names: list[str], position: npt.NDArray[np.float32]) -> bytes:
        msg = self._joint_state(
            header=self._stamp_header(stamp_ns),
            name=names,
            position=np.asarray(position, dtype=np.float64),
            velocity=self._empty_f64,
            effort=self._empty_f64,
        )
        return bytes(self.store.serialize_cdr(msg, JOINT_STATE_T))

    def action(self, values: npt.NDArray[np.float32], label: str = "action") -> bytes:
        """A Float32MultiArray of one dimension named `label` (the action, or the environment state)."""
        n = int(values.shape[0])
        layout = self._layout(dim=[self._dim(label=label, size=n, stride=n)], data_offset=0)
        msg = self._f32_array(layout=layout, data=np.asarray(values, dtype=np.float32))
        return bytes(self.store.serialize_cdr(msg, FLOAT32_ARRAY_T))

    def float32(self, value: float) -> bytes:
        return bytes(self.store.serialize_cdr(self._f32(data=float(value)), FLOAT32_T))

    def boolean(self, value: bool) -> bytes:
        return bytes(self.store.serialize_cdr(self._bool(data=bool(value)), BOOL_T))

    def string(self, text: str) -> bytes:
        return bytes(self.store.serialize_cdr(self._string(data=text), STRING_T))

    def event(self, payload: dict[str, Any]) -> bytes:
        return self.string(json.dumps(payload, sort_keys=True))

    def compress(self, rgb: npt.NDArray[np.uint8]) -> bytes:
        """JPEG/PNG bytes of an HWC RGB image (thread-safe; Pillow releases the GIL while encoding)."""
        buf = io.BytesIO()
        pil = PILImage.fromarray(rgb, mode="RGB")
        if self.image_format == "jpeg":
            pil.save(buf, format="JPEG", quality=self.jpeg_quality)
        else:
            pil.save(buf, format="PNG", compress_level=1)
        return buf.getvalue()

    def camera_info(self, stamp_ns: int, info: dict[str, Any]) -> bytes:
        """A CameraInfo from a camera feature's `info.camera_info` (frame_id, width, height, distortion_model, k, d,
        r, p), as `convert` reads it from a bag."""
        msg = self._camera_info(
            header=self._stamp_header(stamp_ns, frame_id=str(info["frame_id"])),
            height=int(info["height"]),
            width=int(info["width"]),
            distortion_model=str(info["distortion_model"]),
            d=np.asarray(info["d"], dtype=np.float64),
            k=np.asarray(info["k"], dtype=np.float64),
            r=np.asarray(info["r"], dtype=np.float64),
            p=np.asarray(info["p"], dtype=np.float64),
            binning_x=0,
            binning_y=0,
            roi=self._roi(x_offset=0, y_offset=0, height=0, width=0, do_rectify=False),
        )
        return bytes(self.store.serialize_cdr(msg, CAMERA_INFO_T))

    def depth_image(self, stamp_ns: int, camera: str, depth: npt.NDArray[Any]) -> bytes:
        """An Image of an (H, W) depth map, little-endian: uint16 millimetres as 16UC1, float32 metres as 32FC1."""
        h, w = int(depth.shape[0]), int(depth.shape[1])
        metres = depth.dtype == np.float32
        data = np.ascontiguousarray(depth, dtype="<f4" if metres else "<u2").view(np.uint8).reshape(-1)
        header = self._stamp_header(stamp_ns, frame_id=camera)
        encoding, size = ("32FC1", 4) if metres else ("16UC1", 2)
        msg = self._image(header=header, height=h, width=w, encoding=encoding, is_bigendian=0, step=size * w, data=data)
        return bytes(self.store.serialize_cdr(msg, IMAGE_T))

    def mask_image(self, stamp_ns: int, camera: str, mask: npt.NDArray[np.uint16]) -> bytes:
        """An Image of an (H, W) uint16 segmentation mask: `mono16`, little-endian, the ids exactly."""
        h, w = int(mask.shape[0]), int(mask.shape[1])
        data = np.ascontiguousarray(mask, dtype="<u2").view(np.uint8).reshape(-1)
        header = self._stamp_header(stamp_ns, frame_id=camera)
        msg = self._image(header=header, height=h, width=w, encoding="mono16", is_bigendian=0, step=2 * w, data=data)
        return bytes(self.store.serialize_cdr(msg, IMAGE_T))

    def transforms(self, stamp_ns: int, poses: dict[str, dict[str, Any]]) -> bytes:
        """A TFMessage: frame `child` -> its `extrinsics` (parent_frame, position, quaternion [qw, qx, qy, qz])."""
        stamped = []
        for child, pose in poses.items():
            qw, qx, qy, qz = (float(v) for v in pose["quaternion"])
            x, y, z = (float(v) for v in pose["position"])
            stamped.append(
                self._transform_stamped(
                    header=self._stamp_header(stamp_ns, frame_id=str(pose["parent_frame"])),
                    child_frame_id=child,
                    transform=self._transform(
                        translation=self._vector3(x=x, y=y, z=z), rotation=self._quaternion(x=qx, y=qy, z=qz, w=qw)
                    ),
                )
            )
        return bytes(self.store.serialize_cdr(self._tf(transforms=stamped), TF_T))

    def image(self, stamp_ns: int, camera: str, rgb: npt.NDArray[np.uint8], compressed: bytes | None = None) -> bytes:
        """The camera message; `compressed` is `compress(rgb)` when it was already computed elsewhere."""
        header = self._stamp_header(stamp_ns, frame_id=camera)
        h, w = int(rgb.shape[0]), int(rgb.shape[1])
        if self.image_format == "raw":
            data = np.ascontiguousarray(rgb, dtype=np.uint8).reshape(-1)
            msg = self._image(header=header, height=h, width=w, encoding="rgb8", is_bigendian=0, step=3 * w, data=data)
            return bytes(self.store.serialize_cdr(msg, IMAGE_T))
        payload = np.frombuffer(compressed if compressed is not None else self.compress(rgb), dtype=np.uint8)
        msg = self._compressed(header=header, format=self.image_format, data=payload)
        return bytes(self.store.serialize_cdr(msg, COMPRESSED_T))


# sensor_msgs/Image encodings `decode_image` turns into RGB (channels each), and the depth encodings it does not
RGB_ENCODINGS: dict[str, int] = {"rgb8": 3, "bgr8": 3, "rgba8": 4, "bgra8": 4, "mono8": 1}
DEPTH_ENCODINGS = ("16uc1", "32fc1", "mono16")


def decode_image(msg: Any, msgtype: str) -> npt.NDArray[np.uint8]:
    """RGB uint8 HWC from a deserialised `sensor_msgs` Image or CompressedImage."""
    if msgtype.endswith("CompressedImage"):
        with PILImage.open(io.BytesIO(bytes(msg.data))) as im:
            return np.asarray(im.convert("RGB"), dtype=np.uint8)
    enc = str(msg.encoding).lower()
    h, w, step = int(msg.height), int(msg.width), int(msg.step)
    raw = np.asarray(msg.data, dtype=np.uint8)
    channels = RGB_ENCODINGS.get(enc)
    if channels is None:
        raise ValueError(f"unsupported image encoding {msg.encoding!r} ({', '.join(RGB_ENCODINGS)})")
    if min(h, w) < 1 or step < w * channels or raw.size != h * step:
        raise ValueError(f"{w}x{h} {msg.encoding} image with step {step} has {raw.size} bytes")
    rows: npt.NDArray[np.uint8] = raw.reshape(h, step)[:, : w * channels].reshape(h, w, channels)
    if enc == "mono8":
        return np.ascontiguousarray(np.repeat(rows, 3, axis=2))
    rgb = rows[:, :, 2::-1] if enc.startswith("bgr") else rows[:, :, :3]
    return np.ascontiguousarray(rgb)
