"""`dtype: image` features on the episode page: a camera stored as pictures in the data parquet (lerobot's
`dtype: image`), and a segmentation mask (`masks.is_mask`: 16-bit object ids) shown as coloured labels. Frame k's
cell is read from the episode's rows of its data file and sent as a PNG: a camera's picture decoded and encoded
again (PNG or JPEG bytes as stored are never passed through unchecked), a mask's ids each in its own colour
(background black)."""

from __future__ import annotations

import io
from typing import Any

import numpy as np
import numpy.typing as npt
from PIL import Image

from openral_data.errors import NotFound
from openral_data.formats.lerobot_v3.images import decode_image
from openral_data.formats.lerobot_v3.masks import decode_mask, is_mask


def picture_keys(info: dict[str, Any]) -> list[str]:
    """The `dtype: image` features of info.json, in its order (cameras and segmentation masks)."""
    return [k for k, f in info.get("features", {}).items() if isinstance(f, dict) and f.get("dtype") == "image"]


def labels(ids: npt.NDArray[np.uint16]) -> npt.NDArray[np.uint8]:
    """(H, W) object ids as (H, W, 3) colours: 0 black, every other id a fixed bright colour of its own."""
    mixed = (ids.astype(np.uint64) * np.uint64(2654435761)) & np.uint64(0xFFFFFF)
    rgb = np.stack([(mixed >> np.uint64(s)) & np.uint64(0xFF) for s in (16, 8, 0)], axis=-1).astype(np.uint8)
    rgb = np.maximum(rgb, 64)  # never near-black: black is the background
    rgb[ids == 0] = 0
    return rgb


def picture_png(feature: dict[str, Any], cell: object, source: str) -> bytes:
    """One frame's cell as a PNG: a mask as coloured labels, a picture as it is."""
    if cell is None:
        raise NotFound(f"{source}: no picture")
    pixels = labels(decode_mask(cell, source)) if is_mask(feature) else decode_image(cell, source)
    out = io.BytesIO()
    Image.fromarray(pixels, mode="RGB").save(out, format="PNG")
    return out.getvalue()
