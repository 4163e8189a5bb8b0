"""A TFDS build folder's ``features.json`` read as the flat list of keys its Examples hold.

TFDS serializes an RLDS episode as one `tf.train.Example`: the per-step features of the ``steps`` Dataset are
flattened to ``steps/<path>`` keys whose lists hold every step's values one after another (a tensor's values
row-major, an image's or a text's one bytes entry a step); episode-level features (``episode_metadata/<path>``)
hold one value. Tensors (`Tensor`, `Scalar`, `ClassLabel`) must use TFDS's plain encoding ("none"); images are
JPEG or PNG; texts are UTF-8 bytes. Anything else is refused in one line naming the key.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

from openral_data.errors import DatasetError
from openral_data.formats.episodic import ArraySpec, Encoding

# the proto list each TFDS dtype is serialized into
PROTO_LISTS = {
    "bool": "int64_list",
    "int8": "int64_list",
    "int16": "int64_list",
    "int32": "int64_list",
    "int64": "int64_list",
    "uint8": "int64_list",
    "uint16": "int64_list",
    "uint32": "int64_list",
    "float16": "float_list",
    "float32": "float_list",
    "float64": "float_list",
    "bfloat16": "float_list",
    "string": "bytes_list",
}
MAX_DIM = 1 << 20  # a declared dimension above this is refused (no episode step is that wide)


@dataclass(frozen=True)
class Leaf:
    """One serialized key: its spec (one step's, or the one value's for episode-level keys) and its proto list."""

    spec: ArraySpec
    proto_list: str  # "bytes_list" | "float_list" | "int64_list"
    per_step: bool


def leaves(doc: Any, path: Path) -> list[Leaf]:
    """Every serialized key of a parsed features.json, in key order."""
    out: list[Leaf] = []
    top = _dict_features(doc, path, "features")
    for name, feature in sorted(top.items()):
        if _class(feature) == "Dataset" or "sequence" in feature:
            inner = feature.get("sequence", {}).get("feature") if isinstance(feature.get("sequence"), dict) else None
            _walk(inner, name, path, out, per_step=True)
        else:
            _walk(feature, name, path, out, per_step=False)
    return out


def _class(feature: Any) -> str:
    return str(feature.get("pythonClassName", "")).rsplit(".", 1)[-1] if isinstance(feature, dict) else ""


def _dict_features(node: Any, path: Path, key: str) -> dict[str, Any]:
    features = node.get("featuresDict", {}).get("features") if isinstance(node, dict) else None
    if not isinstance(features, dict):
        raise DatasetError(f"{path}: {key}: not a FeaturesDict", code="dataset.invalid")
    return features


def _walk(node: Any, key: str, path: Path, out: list[Leaf], *, per_step: bool) -> None:
    """The leaves under `node` (a FeaturesDict or a leaf feature) at slash path `key`."""
    if isinstance(node, dict) and "featuresDict" in node:
        for name, child in sorted(_dict_features(node, path, key).items()):
            _walk(child, f"{key}/{name}", path, out, per_step=per_step)
        return
    out.append(_leaf(node, key, path, per_step))


def _leaf(node: Any, key: str, path: Path, per_step: bool) -> Leaf:
    where = f"{path}: {key}"
    if not isinstance(node, dict):
        raise DatasetError(f"{where}: not a feature description", code="dataset.invalid")
    if "image" in node:
        image = node["image"]
        fmt = str(image.get("encodingFormat") or "png").lower()
        if fmt not in ("jpeg", "png") or str(image.get("dtype", "uint8")) != "uint8":
            raise DatasetError(f"{where}: {fmt} {image.get('dtype')} images are not read (JPEG/PNG uint8)",
                               code="dataset.unsupported")  # fmt: skip
        encoding: Encoding = "jpeg" if fmt == "jpeg" else "png"
        return Leaf(ArraySpec(key, "uint8", _shape(image, where), encoding), "bytes_list", per_step)
    if "text" in node:
        return Leaf(ArraySpec(key, "bytes", ()), "bytes_list", per_step)
    if "classLabel" in node:
        return Leaf(ArraySpec(key, "int64", ()), "int64_list", per_step)
    tensor = node.get("tensor")
    if not isinstance(tensor, dict):
        raise DatasetError(f"{where}: feature kind {_class(node) or '?'} is not read", code="dataset.unsupported")
    dtype = str(tensor.get("dtype"))
    if dtype not in PROTO_LISTS or str(tensor.get("encoding", "none")) != "none":
        raise DatasetError(f"{where}: tensor of dtype {dtype}, encoding {tensor.get('encoding')} is not read",
                           code="dataset.unsupported")  # fmt: skip
    shape = _shape(tensor, where)
    if -1 in shape:
        raise DatasetError(f"{where}: variable-length tensor {list(shape)} is not read", code="dataset.unsupported")
    spec_dtype = "bytes" if dtype == "string" else dtype
    return Leaf(ArraySpec(key, spec_dtype, shape), PROTO_LISTS[dtype], per_step)


def _shape(node: dict[str, Any], where: str) -> tuple[int, ...]:
    shape = node.get("shape") or {}
    try:
        dims = tuple(int(d) for d in (shape.get("dimensions") or []))
    except (TypeError, ValueError, AttributeError):
        raise DatasetError(f"{where}: shape is not a list of integers", code="dataset.invalid") from None
    if any(d < -1 or d > MAX_DIM for d in dims):
        raise DatasetError(f"{where}: shape {list(dims)} out of range (each dim -1..{MAX_DIM})", code="dataset.invalid")
    return dims
