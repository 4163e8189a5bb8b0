"""`edges.Full`: a camera's frame-to-frame change measured once per episode for every check that judges it (a
frozen span's still scene, a stalled camera, `camera_lag`'s first change), and the first change found decoding
no further than that frame."""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np
import numpy.typing as npt

from openral_data.metrics.quality.camera import luma
from openral_data.metrics.quality.edges import REPEAT, Full

STILL = 6  # the picture holds for frames 0..5, then changes every frame


def test_change_is_decoded_once_and_the_first_change_no_further_than_it() -> None:
    pulled: list[int] = []  # the frames each decode handed out
    decodes: list[int] = []

    def frames() -> Iterator[npt.NDArray[np.uint8]]:
        decodes.append(1)
        for t in range(20):
            pulled.append(t)
            yield np.full((8, 8, 3), 40 + 9 * max(0, t - STILL + 1), dtype=np.uint8)

    full = Full(frames, luma)
    assert full.first_change(10) == STILL and pulled == list(range(STILL + 1))  # stopped at the first change
    assert full.first_change(STILL) is None  # every one of the first 6 frames repeats the one before
    pulled.clear()
    decodes.clear()
    change = full.change()
    assert np.isnan(change[0]) and (change[1:STILL] < REPEAT).all() and (change[STILL:] > 8.9).all()
    assert full.change() is change and full.first_change(10) == STILL  # measured once: no decode again
    assert decodes == [1] and pulled == list(range(20))
