"""Bounded memory: converting a bag holds a few frames, not the bag. Peak RSS (VmHWM) of a conversion
subprocess on a bag with 450 MB of images stays within a small margin of the same conversion on a bag 10x
shorter, and far below the images' size."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import Stores, get_typestore

from tests.support.scenes import write_yaml

H = W = 256
CAM_HZ = 30
# Peak RSS of this process image: VmHWM (KiB) is reset at exec, unlike ru_maxrss, which a child started by
# fork+exec inherits from its parent (here pytest, which may hold torch/lerobot from earlier tests).
MEASURE = """
import atexit, re, sys
report = sys.argv[1]
def peak():
    status = open("/proc/self/status").read()
    open(report, "w").write(re.search(r"VmHWM:\\s+(\\d+) kB", status).group(1))
atexit.register(peak)
sys.argv = ["openral-data", *sys.argv[2:]]
from openral_data.cli import main
main()
"""


def _write_bag(path: Path, seconds: int) -> int:
    """Two raw rgb8 cameras at 30 Hz, JointState at 100 Hz, a command at 20 Hz; returns image bytes."""
    store = get_typestore(Stores.ROS2_HUMBLE)
    t = store.types
    rng = np.random.default_rng(0)
    noise = rng.integers(0, 256, size=(8, H * W * 3), dtype=np.uint8)  # incompressible, varied pixels
    image_bytes = 0
    base = 1_700_000_000 * 10**9
    with Writer(path, version=8, storage_plugin=StoragePlugin.MCAP) as w:
        cams = [w.add_connection(f"/cam{i}/image_raw", "sensor_msgs/msg/Image", typestore=store) for i in (0, 1)]
        js = w.add_connection("/joint_states", "sensor_msgs/msg/JointState", typestore=store)
        cmd = w.add_connection("/cmd", "std_msgs/msg/Float64MultiArray", typestore=store)
        events: list[tuple[int, int]] = [(ms, 0) for ms in range(0, seconds * 1000, 10)]
        events += [(ms, 1) for ms in range(0, seconds * 1000, 50)]
        events += [(k * 1000 // CAM_HZ, 2) for k in range(seconds * CAM_HZ)]
        for k, (ms, kind) in enumerate(sorted(events)):
            ns = base + ms * 10**6
            stamp = t["builtin_interfaces/msg/Time"](sec=ns // 10**9, nanosec=ns % 10**9)
            header = t["std_msgs/msg/Header"](stamp=stamp, frame_id="")
            if kind == 0:
                msg = t["sensor_msgs/msg/JointState"](
                    header=header, name=["a", "b"], position=np.array([ms, -ms], float), velocity=np.zeros(0),
                    effort=np.zeros(0),
                )  # fmt: skip
                w.write(js, ns, store.serialize_cdr(msg, "sensor_msgs/msg/JointState"))
            elif kind == 1:
                layout = t["std_msgs/msg/MultiArrayLayout"](dim=[], data_offset=0)
                msg = t["std_msgs/msg/Float64MultiArray"](layout=layout, data=np.array([ms / 1000.0]))
                w.write(cmd, ns, store.serialize_cdr(msg, "std_msgs/msg/Float64MultiArray"))
            else:
                for conn in cams:
                    msg = t["sensor_msgs/msg/Image"](
                        header=header, height=H, width=W, encoding="rgb8", is_bigendian=0, step=3 * W,
                        data=noise[k % 8],
                    )  # fmt: skip
                    w.write(conn, ns, store.serialize_cdr(msg, "sensor_msgs/msg/Image"))
                    image_bytes += H * W * 3
    return image_bytes


def _peak_rss_mb(tmp: Path, bag: Path, mapping: Path, name: str) -> float:
    report = tmp / f"{name}.rss"
    proc = subprocess.run(
        [sys.executable, "-c", MEASURE, str(report), "convert", str(bag), str(tmp / name), "--mapping", str(mapping),
         "--codec", "h264"],
        capture_output=True, text=True, timeout=900, env=dict(os.environ), check=False,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    return int(report.read_text()) / 1024


@pytest.mark.slow
def test_conversion_memory_does_not_grow_with_the_bag(tmp_path: Path) -> None:
    mapping = write_yaml(
        tmp_path / "m.yaml",
        {
            "fps": 10,
            "task": "noise",
            "state": {"topic": "/joint_states", "joints": ["b", "a"]},
            "action": {"topic": "/cmd", "field": "data"},
            "cameras": {"left": "/cam0/image_raw", "right": "/cam1/image_raw"},
        },
    )
    small_bytes = _write_bag(tmp_path / "small", 4)
    big_bytes = _write_bag(tmp_path / "big", 40)
    assert big_bytes > 400 * 2**20
    small = _peak_rss_mb(tmp_path, tmp_path / "small", mapping, "small_ds")
    big = _peak_rss_mb(tmp_path, tmp_path / "big", mapping, "big_ds")
    print(f"peak RSS: small bag ({small_bytes / 2**20:.0f} MB images) {small:.0f} MB, "
          f"big bag ({big_bytes / 2**20:.0f} MB images) {big:.0f} MB")  # fmt: skip
    # ten times the images, (almost) the same memory: nothing proportional to the bag is held
    assert big - small < 64, (small, big)
    # below the images' size: holding the bag would take more. (Half of it, 225 MB, was this line's bound: the
    # process's own imports and x264's buffers alone reach 230 MB here, with the code of stop 42 as well.)
    assert big < big_bytes / 2**20 * 0.6
    assert sum(1 for _ in (tmp_path / "big_ds" / "data").rglob("*.parquet")) == 1
