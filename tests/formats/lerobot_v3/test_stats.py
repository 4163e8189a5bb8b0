"""Camera statistics: the per-frame histograms are exact counts of the subsampled pixels."""

from __future__ import annotations

import numpy as np

from openral_data.formats.lerobot_v3.stats import IMAGE_SIDE, ImageStatsAccumulator


def test_image_histograms_count_every_subsampled_pixel_per_channel() -> None:
    rng = np.random.default_rng(7)
    frames = [rng.integers(0, 256, (96, 130, 3), dtype=np.uint8) for _ in range(5)]
    frames.append(np.full((96, 130, 3), 255, dtype=np.uint8))  # the top level of every channel
    frames.append(np.zeros((96, 130, 3), dtype=np.uint8))
    acc = ImageStatsAccumulator()
    for f in frames:
        acc.add(f)
    step = -(-130 // IMAGE_SIDE)
    want = np.zeros((3, 256), dtype=np.int64)
    for f in frames:
        for c in range(3):
            want[c] += np.histogram(f[::step, ::step, c], bins=256, range=(0, 256))[0]
    np.testing.assert_array_equal(acc.hist, want)
    assert acc.frames == len(frames)
    pixels = np.concatenate([f[::step, ::step].reshape(-1, 3) for f in frames]) / 255.0
    stats = acc.stats()
    np.testing.assert_allclose(stats["mean"].ravel(), pixels.mean(axis=0), rtol=1e-12)
    np.testing.assert_allclose(stats["std"].ravel(), pixels.std(axis=0), rtol=1e-9)
    assert stats["min"].ravel().tolist() == [0.0] * 3 and stats["max"].ravel().tolist() == [1.0] * 3
