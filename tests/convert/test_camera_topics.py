"""Depth Image decoding details: row padding (`step`), big-endian data, a short buffer and an encoding change
mid-stream (one-line `BagError`s naming the topic); compressedDepth of an unknown flavour."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from openral_data.convert.camera_topics import COMPRESSED, IMAGE, decode_depth
from openral_data.errors import BagError
from tests.support.bags import compressed_depth, depth_m


def _image(d: np.ndarray, encoding: str, pad: int = 0, big: bool = False) -> SimpleNamespace:
    h, w = d.shape
    rows = d.astype(d.dtype.newbyteorder(">" if big else "<")).view(np.uint8).reshape(h, -1)
    data = np.concatenate([rows, np.zeros((h, pad), np.uint8)], axis=1).reshape(-1)
    return SimpleNamespace(
        encoding=encoding, height=h, width=w, step=rows.shape[1] + pad, is_bigendian=int(big), data=data
    )


@pytest.mark.parametrize(("pad", "big"), [(0, False), (6, False), (0, True), (10, True)])
def test_16uc1_and_32fc1_layouts(pad: int, big: bool) -> None:
    mm = np.arange(35, dtype=np.uint16).reshape(5, 7) * 100
    assert np.array_equal(decode_depth(_image(mm, "16UC1", pad, big), IMAGE, "mm", "t"), mm)
    m = depth_m(2)[:5, :7]
    got = decode_depth(_image(m, "32FC1", pad, big), IMAGE, "m", "t")
    assert got.dtype == np.float32 and np.array_equal(got, m, equal_nan=True)


def test_short_buffer_and_encoding_change_are_one_line() -> None:
    msg = _image(np.zeros((4, 4), np.uint16), "16UC1")
    msg.data = msg.data[:-1]
    with pytest.raises(BagError, match=r"^/d: 4x4 16UC1 image with step 8 has 31 bytes$") as err:
        decode_depth(msg, IMAGE, "mm", "/d")
    assert err.value.code == "bag.field"
    with pytest.raises(BagError, match=r"^/d: encoding changed to '32FC1' mid-stream$"):
        decode_depth(_image(np.zeros((4, 4), np.float32), "32FC1"), IMAGE, "mm", "/d")


def test_compressed_depth() -> None:
    data, decoded = compressed_depth(depth_m(1))
    msg = SimpleNamespace(format="32FC1; compressedDepth png", data=np.frombuffer(data, np.uint8))
    assert np.array_equal(decode_depth(msg, COMPRESSED, "m", "/c"), decoded, equal_nan=True)
    rvl = SimpleNamespace(format="16UC1; compressedDepth rvl", data=np.frombuffer(data, np.uint8))
    with pytest.raises(BagError, match="CompressedImage format '16UC1; compressedDepth rvl' is not supported"):
        decode_depth(rvl, COMPRESSED, "mm", "/c")
    broken = SimpleNamespace(format="16UC1; compressedDepth png", data=np.frombuffer(b"\x00" * 20, np.uint8))
    with pytest.raises(BagError, match="compressedDepth message does not decode") as err:
        decode_depth(broken, COMPRESSED, "mm", "/c")
    assert err.value.code == "bag.invalid"
