"""`dtype: image` features of a LeRobot v3 dataset: each frame's picture is stored in the data parquet as the
Hugging Face `Image` struct `{bytes, path}` (lerobot 0.6.1 embeds the PNG bytes), not as a video."""

from __future__ import annotations

import io
from typing import Any

import numpy as np
import numpy.typing as npt
from PIL import Image, UnidentifiedImageError

from openral_data.errors import DatasetError

ENVIRONMENT_STATE = "observation.environment_state"


def image_keys(info: dict[str, Any]) -> list[str]:
    """The features info.json stores as images in the data parquet."""
    return [k for k, f in info.get("features", {}).items() if isinstance(f, dict) and f.get("dtype") == "image"]


def image_bytes(cell: object, source: str) -> bytes:
    """The encoded picture (PNG/JPEG) of one frame's image cell; `source` names it in the one-line error."""
    data = cell.get("bytes") if isinstance(cell, dict) else cell
    if not isinstance(data, bytes) or not data:
        raise DatasetError(f"{source}: no embedded image bytes", code="dataset.invalid")
    return data


def decode_image(cell: object, source: str) -> npt.NDArray[np.uint8]:
    """One frame's image cell decoded to an RGB array (height, width, 3)."""
    try:
        with Image.open(io.BytesIO(image_bytes(cell, source))) as img:
            return np.asarray(img.convert("RGB"), dtype=np.uint8)
    except (UnidentifiedImageError, OSError, ValueError) as exc:
        raise DatasetError(f"{source}: cannot decode image: {exc}", code="dataset.invalid") from None


def media_type(data: bytes) -> str:
    """`image/png` or `image/jpeg` from the bytes' signature (what rerun's EncodedImage is told)."""
    return "image/jpeg" if data[:3] == b"\xff\xd8\xff" else "image/png"
