"""The info.json `features` block and the matching Arrow schemas for data and episodes parquet."""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import Any

import pyarrow as pa

from openral_data.formats.lerobot_v3.depth import DepthSettings
from openral_data.formats.lerobot_v3.encoder import VideoSettings
from openral_data.formats.lerobot_v3.images import ENVIRONMENT_STATE
from openral_data.formats.lerobot_v3.masks import mask_feature
from openral_data.formats.lerobot_v3.stats import STAT_KEYS
from openral_data.types import DatasetSchema

IMAGE_PREFIX = "observation.images."
STATE = "observation.state"
ACTION = "action"
DEFAULT_FEATURES: dict[str, dict[str, Any]] = {
    "timestamp": {"dtype": "float32", "shape": [1], "names": None},
    "frame_index": {"dtype": "int64", "shape": [1], "names": None},
    "episode_index": {"dtype": "int64", "shape": [1], "names": None},
    "index": {"dtype": "int64", "shape": [1], "names": None},
    "task_index": {"dtype": "int64", "shape": [1], "names": None},
}
# Outcome columns, per frame: what happened after the action in this row was taken.
OUTCOME_FEATURES: dict[str, dict[str, Any]] = {
    "next.reward": {"dtype": "float32", "shape": [1], "names": None},
    "next.done": {"dtype": "bool", "shape": [1], "names": None},
    "next.success": {"dtype": "bool", "shape": [1], "names": None},
}
# Our per-episode columns in meta/episodes (lerobot's loader keeps unknown episode columns untouched).
EPISODE_EXTRA_COLUMNS: dict[str, pa.DataType] = {
    "openral.success": pa.bool_(),
    "openral.seed": pa.int64(),
    "openral.initial_state": pa.string(),
    "openral.episode_info": pa.string(),  # JSON from the bridge's end_episode(info=...), e.g. a HAL's record
}


def camera_key(name: str) -> str:
    return IMAGE_PREFIX + name


def camera_name(key: str) -> str:
    """`observation.images.<name>` -> name; another key -> the part after `observation.`, dots as `_`."""
    if key.startswith(IMAGE_PREFIX):
        return key[len(IMAGE_PREFIX) :]
    return key.removeprefix("observation.").replace(".", "_")


def camera_keys(features: dict[str, Any]) -> dict[str, str]:
    """Camera name -> feature key for every `video` or `image` feature, in info.json order (lerobot's
    `camera_keys`). A name is the key after `observation.images.`, or for other keys (`observation.image` of
    lerobot/pusht, `observation.images_depth`...) the key after `observation.` with dots as `_`; a name two keys
    would share keeps the first and the other is named by its whole key, dots as `_`."""
    out: dict[str, str] = {}
    for key, feature in features.items():
        if not isinstance(feature, dict) or feature.get("dtype") not in ("video", "image"):
            continue
        name = camera_name(key)
        if name in out:
            name = key.replace(".", "_")
        out[name] = key
    return out


def writer_camera_keys(names: Iterable[str], features: dict[str, Any] | None = None) -> dict[str, str]:
    """Camera name -> feature key for the cameras `names` of a dataset written with `features`: the key
    `camera_keys(features)` gives the name (a source's own key, e.g. `observation.image`), else `camera_key(name)`."""
    known = camera_keys(features) if features else {}
    return {name: known.get(name, camera_key(name)) for name in names}


def dim_names(feature: dict[str, Any], key: str) -> list[str]:
    """Per-dimension names of a one-axis feature: its `names` list, or the list inside lerobot's one-entry
    `{"motors": [...]}` form, when it names every dimension; else `<key>_<i>`."""
    shape = feature.get("shape")
    size = int(shape[0]) if isinstance(shape, list | tuple) and shape else 1
    names = feature.get("names")
    if isinstance(names, dict) and len(names) == 1:
        names = next(iter(names.values()))
    if isinstance(names, list) and len(names) == size and all(isinstance(n, str) for n in names):
        return list(names)
    return [f"{key}_{i}" for i in range(size)]


def build_features(
    schema: DatasetSchema,
    video: VideoSettings,
    depth: DepthSettings | None = None,
    keys: Mapping[str, str] | None = None,
) -> dict[str, dict[str, Any]]:
    """The features our writer writes for `schema`; a camera's key is `keys[name]` if given (`writer_camera_keys`),
    else `camera_key(name)`; a depth camera's info is `depth`'s (lerobot's defaults if None); a segmentation
    mask is a `dtype: image` feature (masks.py)."""
    features: dict[str, dict[str, Any]] = {}
    for name, shape in schema.cameras.items():
        if shape.segmentation:  # a mask: lossless 16-bit PNGs in the parquet (masks.py)
            features[(keys or {}).get(name) or camera_key(name)] = mask_feature(shape)
            continue
        info = (
            video.feature_info(shape.height, shape.width, schema.fps)
            if shape.depth_unit is None
            else (depth or DepthSettings()).feature_info(shape.height, shape.width, schema.fps, shape.depth_unit)
        )
        features[(keys or {}).get(name) or camera_key(name)] = {
            "dtype": "video",
            "shape": [shape.height, shape.width, 3 if shape.depth_unit is None else 1],
            "names": ["height", "width", "channels"],
            "info": {**info, **shape.info},
        }
    features[STATE] = {"dtype": "float32", "shape": [schema.state_dim], "names": list(schema.state_names)}
    env = schema.environment_state_names
    if env:  # only a source that has one: a recording without it gets no column
        features[ENVIRONMENT_STATE] = {"dtype": "float32", "shape": [len(env)], "names": list(env)}
    features[ACTION] = {"dtype": "float32", "shape": [schema.action_dim], "names": list(schema.action_names)}
    # an outcome the source does not know is not a column: a constant 0 reward or False success would be a claim
    known = {"next.reward": schema.has_reward, "next.done": True, "next.success": schema.has_success}
    features.update({k: f for k, f in OUTCOME_FEATURES.items() if known[k]})
    features.update(DEFAULT_FEATURES)
    for key in schema.frame_extras:
        features[key] = {"dtype": "float32", "shape": [1], "names": None}
    for col in schema.frame_columns:
        names = list(col.names) if col.dtype == "float32" else None
        features[col.key] = {"dtype": col.dtype, "shape": [col.dim], "names": names}
    return features


# a `dtype: image` frame in the data parquet: the Hugging Face `Image` struct (lerobot embeds the PNG bytes)
IMAGE_STRUCT = pa.struct([("bytes", pa.binary()), ("path", pa.string())])
PICTURE_DTYPES = ("video", "image")  # features whose statistics are per channel, shape (3, 1, 1)


def _arrow_type(feature: dict[str, Any]) -> pa.DataType:
    if feature["dtype"] == "image":
        return IMAGE_STRUCT
    base = {"float32": pa.float32(), "int64": pa.int64(), "bool": pa.bool_()}[feature["dtype"]]
    shape = feature["shape"]
    return base if shape == [1] else pa.list_(base, shape[0])


def data_schema(features: dict[str, dict[str, Any]]) -> pa.Schema:
    return pa.schema([(k, _arrow_type(f)) for k, f in features.items() if f["dtype"] != "video"])


def episodes_schema(features: dict[str, dict[str, Any]]) -> pa.Schema:
    fields: list[tuple[str, pa.DataType]] = [
        ("episode_index", pa.int64()),
        ("tasks", pa.list_(pa.string())),
        ("length", pa.int64()),
        ("data/chunk_index", pa.int64()),
        ("data/file_index", pa.int64()),
        ("dataset_from_index", pa.int64()),
        ("dataset_to_index", pa.int64()),
    ]
    for key, f in features.items():
        if f["dtype"] == "video":
            fields += [
                (f"videos/{key}/chunk_index", pa.int64()),
                (f"videos/{key}/file_index", pa.int64()),
                (f"videos/{key}/from_timestamp", pa.float64()),
                (f"videos/{key}/to_timestamp", pa.float64()),
            ]
    for key, f in features.items():
        value: pa.DataType = (
            pa.list_(pa.list_(pa.list_(pa.float64()))) if f["dtype"] in PICTURE_DTYPES else pa.list_(pa.float64())
        )
        for stat in STAT_KEYS:
            fields.append((f"stats/{key}/{stat}", pa.list_(pa.int64()) if stat == "count" else value))
    fields += [("meta/episodes/chunk_index", pa.int64()), ("meta/episodes/file_index", pa.int64())]
    fields += list(EPISODE_EXTRA_COLUMNS.items())
    return pa.schema(fields)
