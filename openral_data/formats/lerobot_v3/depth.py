"""Depth cameras as lerobot 0.6.1 writes them: 12-bit quantized depth in a lossless HEVC `gray12le` video.

lerobot's `DepthEncoderConfig` (lerobot/configs/video.py) and `quantize_depth` / `dequantize_depth`
(lerobot/datasets/depth_utils.py), reproduced without importing lerobot:

* a depth map (uint16 millimetres, or float32 metres) becomes codes 0..4095:
  ``norm = (log(d + shift) - log(depth_min + shift)) / (log(depth_max + shift) - log(depth_min + shift))``
  (``use_log``; linear: ``(d - depth_min) / (depth_max - depth_min)``), ``code = clip(rint(norm * 4095))``,
  in the input's own unit (``depth_min``, ``depth_max``, ``shift`` are metres, scaled to mm for mm input);
* the codes are encoded with HEVC (libx265, ``x265-params lossless=1``) in ``gray12le``: the video holds them
  exactly; lerobot's loader decodes them and inverts the mapping (clipped to [depth_min, depth_max]);
* the feature's ``info`` carries ``is_depth_map: true``, ``depth_unit`` (``mm`` / ``m``, the unit of the
  source frames and of the stats) and the quantizer as ``video.depth_min/depth_max/shift/use_log``;
* stats are those of the source frames in ``depth_unit``, shape (1, 1, 1), not divided by 255.

Invalid depth: lerobot has no separate marker, its quantizer clips. A pixel below ``depth_min`` (a RealSense 0)
gets code 0 and loads as ``depth_min``; above ``depth_max`` code 4095 and loads as ``depth_max``. For 32FC1
(REP 118) we map NaN ("no return") and -inf ("too close") to code 0, +inf ("too far") to code 4095, so they load
as ``depth_min`` / ``depth_max`` too. Non-finite pixels are left out of the stats (lerobot's would be NaN).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Literal, Self

import av
import numpy as np
import numpy.typing as npt

from openral_data.formats.lerobot_v3.stats import IMAGE_SIDE, QUANTILES, ImageStatsAccumulator, Stats

DepthUnit = Literal["mm", "m"]
QMAX = 4095  # 12-bit codes
MM_PER_METRE = 1000.0
_HIST_BINS = 1 << 16  # stats quantiles: 1 mm bins over 0..65.535 m (all of 16UC1)


@dataclass(frozen=True)
class DepthSettings:
    """lerobot's `DepthEncoderConfig` quantizer (its defaults); the video side is fixed to lerobot's
    (hevc, gray12le, g=2, crf=30, x265 lossless)."""

    depth_min: float = 0.01  # metres at code 0
    depth_max: float = 10.0  # metres at code 4095
    shift: float = 3.5  # metres added before the log
    use_log: bool = True

    encoder = "libx265"
    pix_fmt = "gray12le"
    g = 2
    crf = 30

    @staticmethod
    def size_problem(height: int, width: int) -> str | None:
        if height < 16 or width < 16 or height % 2 or width % 2:
            return f"{width}x{height}: a depth video needs even width and height of at least 16"
        return None

    def options(self) -> dict[str, str]:
        """lerobot's codec options for hevc (g, crf, x265-params); x265's banner is silenced (log-level)."""
        return {"g": str(self.g), "crf": str(self.crf), "x265-params": "lossless=1:log-level=error"}

    def feature_info(self, height: int, width: int, fps: int, unit: DepthUnit) -> dict[str, Any]:
        """The `info` block lerobot 0.6.1 writes for a depth video feature."""
        return {
            "is_depth_map": True,
            "depth_unit": unit,
            "video.height": height,
            "video.width": width,
            "video.codec": "hevc",
            "video.pix_fmt": self.pix_fmt,
            "video.fps": fps,
            "video.channels": 1,
            "has_audio": False,
            "video.g": self.g,
            "video.crf": self.crf,
            "video.preset": None,
            "video.fast_decode": 0,
            "video.video_backend": "pyav",
            "video.extra_options": {"x265-params": "lossless=1"},
            "video.depth_min": self.depth_min,
            "video.depth_max": self.depth_max,
            "video.shift": self.shift,
            "video.use_log": self.use_log,
        }

    @classmethod
    def from_info(cls, info: dict[str, Any]) -> Self:
        """The quantizer of a depth feature's `info` (lerobot's defaults for missing keys)."""
        d = cls()
        return cls(
            depth_min=float(info.get("video.depth_min", d.depth_min)),
            depth_max=float(info.get("video.depth_max", d.depth_max)),
            shift=float(info.get("video.shift", d.shift)),
            use_log=bool(info.get("video.use_log", d.use_log)),
        )

    def _in(self, unit: DepthUnit) -> tuple[np.float32, np.float32, np.float32]:
        k = 1.0 if unit == "m" else MM_PER_METRE
        return np.float32(self.depth_min * k), np.float32(self.depth_max * k), np.float32(self.shift * k)

    def quantize(self, depth: npt.NDArray[Any], unit: DepthUnit) -> npt.NDArray[np.uint16]:
        """(H, W) depth in `unit` -> 12-bit codes, exactly as lerobot's `quantize_depth` (float32 math)."""
        d = depth.astype(np.float32)
        lo, hi, shift = self._in(unit)
        with np.errstate(invalid="ignore", divide="ignore"):
            if self.use_log:
                log_min, log_max = math.log(float(lo + shift)), math.log(float(hi + shift))
                norm = (np.log(d + shift) - log_min) / (log_max - log_min)
            else:
                norm = (d - lo) / (hi - lo)
            codes = np.rint(norm * QMAX)
        codes[np.isnan(d) | np.isneginf(d)] = 0
        codes[np.isposinf(d)] = QMAX
        return np.asarray(codes.clip(0, QMAX), dtype=np.uint16)

    def dequantize(self, codes: npt.NDArray[Any]) -> npt.NDArray[np.float32]:
        """Codes -> float32 metres in [depth_min, depth_max], as lerobot's `dequantize_depth` (numpy path)."""
        if self.use_log:
            log_min, log_max = math.log(self.depth_min + self.shift), math.log(self.depth_max + self.shift)
            scale, offset = (log_max - log_min) / QMAX, log_min
        else:
            scale, offset = (self.depth_max - self.depth_min) / QMAX, self.depth_min
        buf = np.asarray(codes, dtype=np.float32) * np.float32(scale) + np.float32(offset)
        if self.use_log:
            buf = np.exp(buf) - np.float32(self.shift)
        return np.asarray(np.clip(buf, self.depth_min, self.depth_max), dtype=np.float32)

    def to_millimetres(self, codes: npt.NDArray[Any]) -> npt.NDArray[np.uint16]:
        """Codes -> uint16 millimetres (16UC1), as lerobot's loader returns them (rounded)."""
        mm = np.rint(self.dequantize(codes) * np.float32(MM_PER_METRE))
        return np.asarray(np.clip(mm, 0, 65535), dtype=np.uint16)


@dataclass(frozen=True)
class DepthStream:
    """How one depth camera's frames become video frames and stats: the quantizer and the frames' unit."""

    settings: DepthSettings
    unit: DepthUnit

    def frame(self, depth: npt.NDArray[Any]) -> av.VideoFrame:
        return av.VideoFrame.from_ndarray(self.settings.quantize(depth, self.unit), format=self.settings.pix_fmt)


def decode_codes(frame: av.VideoFrame) -> npt.NDArray[np.uint16]:
    """The 12-bit codes of a decoded depth video frame."""
    return np.asarray(frame.to_ndarray(format="gray12le"), dtype=np.uint16)


class DepthStatsAccumulator:
    """Stats of depth frames in their own unit over finite pixels (strided to <= 64 px a side, as images):
    exact min, max, mean, std; quantiles from 1 mm bins. Same interface as `ImageStatsAccumulator`."""

    def __init__(self, unit: DepthUnit) -> None:
        self.unit: DepthUnit = unit
        self.frames = 0
        self.n = 0
        self.total = 0.0
        self.total_sq = 0.0
        self.low = math.inf
        self.high = -math.inf
        self.hist = np.zeros(_HIST_BINS, dtype=np.int64)

    def add(self, frame: npt.NDArray[Any]) -> None:
        h, w = frame.shape[:2]
        step = max(1, -(-max(h, w) // IMAGE_SIDE))
        px = np.asarray(frame[::step, ::step], dtype=np.float64).ravel()
        px = px[np.isfinite(px)]
        self.frames += 1
        if not px.size:
            return
        self.n += px.size
        self.total += float(px.sum())
        self.total_sq += float(np.square(px).sum())
        self.low, self.high = min(self.low, float(px.min())), max(self.high, float(px.max()))
        mm = px if self.unit == "mm" else px * MM_PER_METRE
        bins = np.clip(np.rint(mm), 0, _HIST_BINS - 1).astype(np.int64)
        self.hist += np.bincount(bins, minlength=_HIST_BINS)

    def merge(self, other: DepthStatsAccumulator) -> None:
        self.frames += other.frames
        self.n += other.n
        self.total += other.total
        self.total_sq += other.total_sq
        self.low, self.high = min(self.low, other.low), max(self.high, other.high)
        self.hist += other.hist

    def to_json(self) -> dict[str, Any]:
        nz = np.flatnonzero(self.hist)
        return {
            "depth_unit": self.unit,
            "frames": self.frames,
            "n": self.n,
            "sum": self.total,
            "sum_sq": self.total_sq,
            "min": self.low if self.n else None,
            "max": self.high if self.n else None,
            "bins": nz.tolist(),
            "counts": self.hist[nz].tolist(),
        }

    @classmethod
    def from_json(cls, saved: dict[str, Any]) -> Self:
        acc = cls("m" if saved["depth_unit"] == "m" else "mm")
        acc.frames, acc.n = int(saved["frames"]), int(saved["n"])
        acc.total, acc.total_sq = float(saved["sum"]), float(saved["sum_sq"])
        if acc.n:
            acc.low, acc.high = float(saved["min"]), float(saved["max"])
        acc.hist[np.asarray(saved["bins"], dtype=np.int64)] = np.asarray(saved["counts"], dtype=np.int64)
        return acc

    def stats(self) -> Stats:
        if self.n == 0:
            raise ValueError("no finite depth pixels accumulated")
        mean = self.total / self.n
        var = max(self.total_sq / self.n - mean * mean, 0.0)
        cdf = np.cumsum(self.hist) / float(self.hist.sum())
        scale = 1.0 if self.unit == "mm" else 1.0 / MM_PER_METRE
        out: Stats = {
            "min": np.array([self.low]),
            "max": np.array([self.high]),
            "mean": np.array([mean]),
            "std": np.array([math.sqrt(var)]),
            "count": np.array([self.frames], dtype=np.int64),
        }
        for key, q in QUANTILES.items():
            level = min(_HIST_BINS - 1, int(np.searchsorted(cdf, q))) * scale
            out[key] = np.array([min(max(level, self.low), self.high)])
        return {k: (v if k == "count" else v.reshape(1, 1, 1)) for k, v in out.items()}


CameraStats = ImageStatsAccumulator | DepthStatsAccumulator


def camera_stats(depth_unit: DepthUnit | None) -> CameraStats:
    """An empty accumulator for a colour camera (None) or a depth camera in `depth_unit`."""
    return ImageStatsAccumulator() if depth_unit is None else DepthStatsAccumulator(depth_unit)


def camera_stats_from_json(saved: dict[str, Any]) -> CameraStats:
    """A camera's accumulator as `.openral/image_hist.json` keeps it (`to_json`)."""
    if "depth_unit" in saved:
        return DepthStatsAccumulator.from_json(saved)
    return ImageStatsAccumulator.from_json(saved)


def merge_camera_stats(into: CameraStats, other: CameraStats) -> None:
    """`into.merge(other)` for two accumulators of the same kind."""
    if isinstance(into, DepthStatsAccumulator):
        if not isinstance(other, DepthStatsAccumulator):
            raise TypeError("cannot merge colour statistics into depth statistics")
        into.merge(other)
        return
    if not isinstance(other, ImageStatsAccumulator):
        raise TypeError("cannot merge depth statistics into colour statistics")
    into.merge(other)
