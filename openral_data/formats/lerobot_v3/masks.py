"""Segmentation masks as `dtype: image` features: lossless 16-bit greyscale PNGs in the data parquet.

A mask frame is (H, W) uint16 object ids (0 = background). Each frame is one PNG (mode `I;16`) in the Hugging Face
`Image` struct of its row, so lerobot 0.6.1 loads it (its `pil_to_chw_tensor` keeps 16-bit pictures in their
native units) as float32 (1, H, W) holding the ids exactly. The feature is `shape [H, W, 1]` and its `info` says
`is_segmentation_mask: true` and names the ids (`segmentation_ids`: {"<id>": name}).

Statistics are those of the ids themselves, not divided by 255 (lerobot's loader gives ids, not [0, 1] levels; a
depth map is kept in its units the same way): per episode exact over every frame's pixels spatially strided to
<= 64 px a side, shape (1, 1, 1); the dataset level merges episodes as numeric features are merged.
"""

from __future__ import annotations

import io
from typing import Any

import numpy as np
import numpy.typing as npt
import pyarrow as pa
from PIL import Image, UnidentifiedImageError

from openral_data.errors import DatasetError
from openral_data.formats.lerobot_v3.images import image_bytes
from openral_data.formats.lerobot_v3.stats import IMAGE_SIDE, Stats, numeric_stats
from openral_data.types import CameraShape

MASK_FLAG = "is_segmentation_mask"
MASK_IDS = "segmentation_ids"


def is_mask(feature: dict[str, Any]) -> bool:
    """Whether a feature of info.json is a segmentation mask (`info.is_segmentation_mask`)."""
    info = feature.get("info")
    return isinstance(info, dict) and info.get(MASK_FLAG) is True


def mask_feature(shape: CameraShape) -> dict[str, Any]:
    """The info.json feature of a segmentation stream (its `shape.info` carries `segmentation_ids`)."""
    return {
        "dtype": "image",
        "shape": [shape.height, shape.width, 1],
        "names": ["height", "width", "channels"],
        "info": {MASK_FLAG: True, **shape.info},
    }


def encode_mask(mask: npt.NDArray[np.uint16]) -> bytes:
    """One mask frame as a 16-bit greyscale PNG."""
    out = io.BytesIO()
    Image.fromarray(np.ascontiguousarray(mask, dtype=np.uint16)).save(out, format="PNG")
    return out.getvalue()


def decode_mask(cell: object, source: str) -> npt.NDArray[np.uint16]:
    """One frame's mask cell back to (H, W) uint16 ids; `source` names it in the one-line error."""
    try:
        with Image.open(io.BytesIO(image_bytes(cell, source))) as img:
            if img.mode not in ("I;16", "I;16B", "I;16L", "I", "L"):
                raise DatasetError(
                    f"{source}: a segmentation mask is {img.mode}, not greyscale", code="dataset.invalid"
                )
            ids = np.asarray(img)
    except (UnidentifiedImageError, OSError, ValueError) as exc:
        raise DatasetError(f"{source}: cannot decode image: {exc}", code="dataset.invalid") from None
    if ids.min(initial=0) < 0 or ids.max(initial=0) > np.iinfo(np.uint16).max:
        raise DatasetError(f"{source}: segmentation ids outside uint16", code="dataset.invalid")
    return ids.astype(np.uint16)


def mask_stats(frames: list[npt.NDArray[np.uint16]]) -> Stats:
    """The statistics of an episode's masks (ids, shape (1, 1, 1)); `count` is the number of frames."""
    h, w = frames[0].shape[:2]
    step = max(1, -(-max(h, w) // IMAGE_SIDE))
    px = np.concatenate([f[::step, ::step].reshape(-1) for f in frames]).reshape(-1, 1)
    stats = numeric_stats(px)
    return {
        k: np.array([len(frames)], dtype=np.int64) if k == "count" else v.reshape(1, 1, 1) for k, v in stats.items()
    }


class MaskColumn:
    """One episode's frames of a mask stream: their PNGs (the parquet column) and their statistics."""

    def __init__(self) -> None:
        self.pngs: list[bytes] = []
        self._sampled: list[npt.NDArray[np.uint16]] = []

    def add(self, mask: npt.NDArray[np.uint16]) -> None:
        self.pngs.append(encode_mask(mask))
        h, w = mask.shape[:2]
        step = max(1, -(-max(h, w) // IMAGE_SIDE))
        self._sampled.append(np.ascontiguousarray(mask[::step, ::step]))

    def array(self, struct: pa.DataType) -> pa.Array:
        """The column in the `Image` struct `struct` (`features.IMAGE_STRUCT`)."""
        return pa.array([{"bytes": b, "path": None} for b in self.pngs], type=struct)

    def stats(self) -> Stats:
        return mask_stats(self._sampled)
