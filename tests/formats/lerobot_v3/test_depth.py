"""Depth quantization: our codes are lerobot 0.6.1's `quantize_depth` codes (mm and m input, log and linear), our
dequantization is its `dequantize_depth`; invalid 32FC1 pixels take the codes we document; depth stats survive
their `.openral/image_hist.json` round trip."""

from __future__ import annotations

import json

import numpy as np
import pytest

from openral_data.formats.lerobot_v3.depth import (
    DepthSettings,
    DepthStatsAccumulator,
    camera_stats_from_json,
)

SETTINGS = [DepthSettings(), DepthSettings(depth_min=0.2, depth_max=4.0, use_log=False), DepthSettings(shift=0.5)]


@pytest.mark.parametrize("settings", SETTINGS)
def test_codes_are_lerobots(settings: DepthSettings) -> None:
    from lerobot.datasets.depth_utils import dequantize_depth, quantize_depth

    rng = np.random.default_rng(3)
    mm = rng.integers(0, 15000, (40, 50)).astype(np.uint16)
    m = rng.uniform(0.0, 12.0, (40, 50)).astype(np.float32)
    kw = {"depth_min": settings.depth_min, "depth_max": settings.depth_max, "shift": settings.shift}
    kw["use_log"] = settings.use_log
    for depth, unit in ((mm, "mm"), (m, "m")):
        ours = settings.quantize(depth, unit)  # type: ignore[arg-type]
        theirs = quantize_depth(depth, video_backend=None, input_unit=unit, **kw)
        assert np.array_equal(ours, theirs), unit
        back = dequantize_depth(theirs, output_unit="m", output_tensor=False, **kw)
        assert np.allclose(settings.dequantize(ours), back[0], rtol=1e-6, atol=1e-6)
        mm_back = dequantize_depth(theirs, output_unit="mm", output_tensor=False, **kw)
        assert np.abs(settings.to_millimetres(ours).astype(int) - mm_back[0].astype(int)).max() <= 1


def test_invalid_32fc1_pixels() -> None:
    """NaN and -inf (no return, too close) -> code 0 (loads as depth_min); +inf (too far) -> 4095 (depth_max)."""
    d = np.array([[np.nan, -np.inf, np.inf, 0.0, 1.0, 50.0]], dtype=np.float32)
    codes = DepthSettings().quantize(d, "m")
    assert codes.tolist()[0][:4] == [0, 0, 4095, 0] and codes[0, 5] == 4095 and 0 < codes[0, 4] < 4095
    assert DepthSettings().dequantize(codes)[0, :3].tolist() == pytest.approx([0.01, 0.01, 10.0], rel=1e-5)


def test_depth_stats_round_trip() -> None:
    acc = DepthStatsAccumulator("m")
    acc.add(np.array([[0.5, np.nan], [1.5, np.inf]], dtype=np.float32))
    other = DepthStatsAccumulator("m")
    other.add(np.array([[2.5, 3.5], [4.5, 5.5]], dtype=np.float32))
    acc.merge(other)
    back = camera_stats_from_json(json.loads(json.dumps(acc.to_json())))
    assert isinstance(back, DepthStatsAccumulator)
    s, t = acc.stats(), back.stats()
    for key in s:
        assert np.array_equal(s[key], t[key]), key
    px = np.array([0.5, 1.5, 2.5, 3.5, 4.5, 5.5])
    assert s["mean"].shape == (1, 1, 1) and s["mean"][0, 0, 0] == pytest.approx(px.mean())
    assert (s["min"][0, 0, 0], s["max"][0, 0, 0], int(s["count"][0])) == (0.5, 5.5, 2)
    assert s["q50"][0, 0, 0] == pytest.approx(np.quantile(px, 0.5), abs=1.0)
