"""Depth cameras on the episode page: lerobot's depth videos are 12-bit HEVC (`formats/lerobot_v3/depth.py`),
which browsers do not play, so frame k is decoded here (`frames.decode_episode_video`, as lerobot's loader
dequantizes it, in millimetres; the mp4 found and contained as every video) and sent as a grey PNG: near bright,
far dark, over the frame's own range of valid depth (pixels at the quantizer's floor are black)."""

from __future__ import annotations

import io
import itertools
from pathlib import Path
from typing import Any

import numpy as np
from PIL import Image

from openral_data.errors import NotFound
from openral_data.formats.lerobot_v3.frames import decode_episode_video, depth_settings
from openral_data.formats.lerobot_v3.variants import feature_info


def depth_unit(info: dict[str, Any], key: str) -> str | None:
    """`mm`/`m` (the unit its frames were recorded in) when video feature `key` is a depth map, else None."""
    settings = depth_settings(info, key)
    if settings is None:
        return None
    return str(feature_info(info["features"][key]).get("depth_unit") or "mm")


def depth_png(root: Path, info: dict[str, Any], row: dict[str, Any], key: str, frame: int) -> bytes:
    """Frame `frame` of the episode's depth video `key` (meta/episodes `row`) as a grey PNG."""
    if not 0 <= frame < int(row["length"]):
        raise NotFound(f"no frame {frame}")
    decoded = next(itertools.islice(decode_episode_video(root, info, row, key), frame, None), None)
    if decoded is None:
        raise NotFound(f"{key}: frame {frame} not in the video")
    mm = np.asarray(decoded, dtype=np.float64).reshape(decoded.shape[0], decoded.shape[1])
    settings = depth_settings(info, key)
    floor = settings.depth_min * 1000.0 if settings is not None else 0.0
    valid = mm > floor
    grey = np.zeros(mm.shape, dtype=np.uint8)
    if valid.any():
        lo, hi = float(mm[valid].min()), float(mm[valid].max())
        scaled = 1.0 - (mm - lo) / (hi - lo if hi > lo else 1.0)
        grey[valid] = np.rint(40 + 215 * np.clip(scaled[valid], 0.0, 1.0)).astype(np.uint8)
    out = io.BytesIO()
    Image.fromarray(grey, mode="L").save(out, format="PNG")
    return out.getvalue()
