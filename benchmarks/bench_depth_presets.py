"""What a depth frame costs to encode with lerobot 0.6.1's depth encoder, at each of x265's presets.

lerobot's default depth encoder (`DepthEncoderConfig`: HEVC via libx265, ``gray12le``, g=2, crf=30,
``x265-params lossless=1``, no preset: x265's ``medium``) is what `record` writes for a RealSense's depth
(`openral_data/formats/lerobot_v3/depth.py`, `DepthSettings`). Lossless HEVC keeps every 12-bit code whatever
the preset, so a faster preset changes only the CPU and the bytes; `DepthEncoderConfig.preset` is lerobot's own
setting for it. This measures, per preset, the CPU seconds and bytes of a 640x480 frame, and checks each video
decodes to exactly the codes it was fed (else the script exits 1).

Two sources of depth, each `--frames` frames, quantized with lerobot's defaults (`DepthSettings.quantize`):

* **slope**: bench_capture.py's RealSense source (tests/support/realsense.py `slope_mm`: a plane 25 mm further
  each frame, no noise);
* **noisy**: the same plane with a 160 mm disc moving across it, Gaussian noise (sigma 4 mm, as a stereo
  camera's at about a metre) and 2 % of pixels invalid (0: no return), seeded.

One encoder thread each (``pools=1``, ``frame-threads=1``): CPU seconds per frame are the figure; at 30 fps a
depth camera needs ``30 x cpu/frame`` cores. Presets alternate within each repetition; medians of
``--repeats``.

    .venv/bin/python benchmarks/bench_depth_presets.py                # 60 frames, 3 repeats
    .venv/bin/python benchmarks/bench_depth_presets.py --frames 30 --repeats 1
"""

from __future__ import annotations

import argparse
import io
import statistics
import sys
import time
from pathlib import Path
from typing import Any

import av
import numpy as np
import numpy.typing as npt

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from openral_data.formats.lerobot_v3.depth import DepthSettings, decode_codes  # noqa: E402
from tests.support.realsense import slope_mm  # noqa: E402

W, H, RATE = 640, 480, 30
PRESETS = (None, "veryfast", "superfast", "ultrafast")  # None: lerobot's default (x265's own, medium)
Codes = npt.NDArray[np.uint16]


def sources(n: int) -> dict[str, list[Codes]]:
    settings = DepthSettings()
    rng = np.random.default_rng(0)
    y, x = np.mgrid[0:H, 0:W]
    noisy = []
    for k in range(n):
        d = slope_mm(W, H, k).astype(np.float64)
        d += 160.0 * (((x - 160 - 4 * k) ** 2 + (y - 240) ** 2) < 80**2)
        d += rng.normal(0.0, 4.0, (H, W))
        d[rng.random((H, W)) < 0.02] = 0.0
        noisy.append(settings.quantize(np.clip(d, 0, 65535).astype(np.uint16), "mm"))
    return {"slope": [settings.quantize(slope_mm(W, H, k), "mm") for k in range(n)], "noisy": noisy}


def encode(codes: list[Codes], preset: str | None) -> tuple[float, int]:
    """CPU seconds (this process) and bytes of one mp4 of `codes`; exits 1 unless it decodes to them exactly."""
    settings = DepthSettings()
    options = settings.options()
    options["x265-params"] += ":pools=1:frame-threads=1"
    if preset is not None:
        options["preset"] = preset
    buf = io.BytesIO()
    with av.open(buf, "w", format="mp4") as out:
        stream: Any = out.add_stream(settings.encoder, rate=RATE)
        stream.width, stream.height, stream.pix_fmt, stream.options = W, H, settings.pix_fmt, options
        start = time.process_time()
        for frame in codes:
            out.mux(stream.encode(av.VideoFrame.from_ndarray(frame, format=settings.pix_fmt)))
        out.mux(stream.encode())
        cpu = time.process_time() - start
    size = buf.getbuffer().nbytes
    buf.seek(0)
    with av.open(buf, "r") as got:
        decoded = [decode_codes(f) for f in got.decode(video=0)]
    if len(decoded) != len(codes) or not all(np.array_equal(a, b) for a, b in zip(decoded, codes, strict=True)):
        sys.exit(f"preset {preset}: the video does not hold the codes it was fed")
    return cpu, size


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=60)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    for name, codes in sources(args.frames).items():
        runs: dict[str | None, list[tuple[float, int]]] = {p: [] for p in PRESETS}
        for _ in range(args.repeats):
            for preset in PRESETS:
                runs[preset].append(encode(codes, preset))
        base = statistics.median(cpu for cpu, _ in runs[None])
        print(f"{name} ({args.frames} frames {W}x{H}, median of {args.repeats}; lossless: every code decoded back)")
        for preset, got in runs.items():
            cpu = statistics.median(c for c, _ in got) / args.frames
            size = got[0][1] / args.frames
            print(
                f"  {preset or 'default (medium)':16} {cpu:.4f} CPU-s/frame  {cpu * RATE:4.2f} cores at {RATE} fps  "
                f"{base / args.frames / cpu:4.2f}x faster  {size / 1000:6.1f} kB/frame"
            )


if __name__ == "__main__":
    main()
