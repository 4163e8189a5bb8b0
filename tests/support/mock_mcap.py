"""Check a mock-scene MCAP recording message by message against what the mock produced."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from openral_data.formats.mcap import finished_bags
from openral_data.formats.mcap.messages import decode_image
from tests.support.mcap import check_bag

COLOUR_TOL = 4.0


def verify_mock_bags(
    root: Path, fps: int = 20, image_format: str = "jpeg", tolerance: float | None = None
) -> list[int]:
    """Every finished episode bag under `root` passes all three readers and holds the mock's values.

    Images must match exactly unless lossy (jpeg, or a `tolerance` for images that went through a codec)."""
    tol = tolerance if tolerance is not None else (COLOUR_TOL if image_format == "jpeg" else 0.0)
    lengths = []
    bags = finished_bags(root)
    assert [b.name for b in bags] == [f"episode_{i:06d}" for i in range(len(bags))]
    suffix = "image_raw" if image_format == "raw" else "image/compressed"
    for e, bag in enumerate(bags):
        topics = check_bag(bag)
        events = [json.loads(msg.data) for _, msg in topics["/openral/episode"]]
        assert [ev["event"] for ev in events] == ["start", "end"]
        start, end = events
        assert start["episode"] == e and start["fps"] == fps
        n = end["length"]
        lengths.append(n)
        states = topics["/joint_states"]
        assert len(states) == n == len(topics["/action"]) == len(topics["/reward"])
        base = states[0][0]
        assert [m.data for _, m in topics["/task"]] == ["pick up the mock cube"]
        for t, (ns, js) in enumerate(states):
            assert ns == base + round(t / fps * 1e9)  # the producer's clock, not a counter
            assert js.header.stamp.sec * 1_000_000_000 + js.header.stamp.nanosec == ns
            assert list(js.name) == start["state_names"]
            assert js.position[0] == t and js.position[1] == e and not js.position[2:].any()
            action_ns, action = topics["/action"][t]
            assert action_ns == ns and action.data.dtype == np.float32
            assert action.data.shape == (len(start["action_names"]),)
        for cam in start["cameras"]:
            images = topics[f"/camera/{cam}/{suffix}"]
            assert len(images) == n
            for t, (ns, msg) in enumerate(images):
                assert ns == states[t][0] and msg.header.frame_id == cam
                if image_format != "raw":
                    assert msg.format == image_format
                rgb = decode_image(msg, "sensor_msgs/msg/Image" if image_format == "raw" else "CompressedImage")
                err = np.abs(rgb.reshape(-1, 3).mean(axis=0) - np.array([t % 256, e % 256, 128])).max()
                assert err <= tol, (cam, e, t, err)
    return lengths
