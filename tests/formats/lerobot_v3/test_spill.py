"""Frames spilled behind a slow encoder (formats/lerobot_v3/spill.py): written on a thread of their own, so a disk
that blocks never stalls the producer; a disk that is full, or the spill cap, fails the episode in flight with one
line while every committed episode stays loadable."""

from __future__ import annotations

import os
import shutil
import threading
from pathlib import Path

import av
import numpy as np
import pytest

from openral_data.errors import DiskError
from openral_data.formats.lerobot_v3 import VideoSettings, WriterConfig
from openral_data.formats.lerobot_v3.video import ENCODE_DELAY_ENV, EncoderWorker
from openral_data.runtime.bridge import DatasetBridge
from tests.support.patterned import check_loads, unit_schema, write_dataset, write_episodes

H264 = VideoSettings(codec="h264")


def _levels(path: Path) -> list[float]:
    container = av.open(str(path))
    try:
        return [float(f.to_ndarray(format="gray").mean()) for f in container.decode(video=0)]
    finally:
        container.close()


def test_a_blocked_disk_never_stalls_the_producer_and_keeps_frame_order(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The first spilled frame's file is a FIFO nobody reads: opening it blocks, as a hung disk would. The
    producer still hands over every frame (the spill thread is the one stuck; the old code opened the file on the
    producer's thread and waited forever), and the encoder, not waiting on the disk either, takes the frames not yet
    on disk from memory: the video is complete, in order, before the disk answers."""
    monkeypatch.setenv(ENCODE_DELAY_ENV, "0.1")  # a throttled real encoder: frames beyond the queue spill
    out = tmp_path / "ep.mp4"
    fifo = out.with_name(out.name + ".spill") / ".000000.npy.tmp"
    fifo.parent.mkdir()
    os.mkfifo(fifo)
    worker = EncoderWorker("cam", H264, fps=10, queue_size=1, spill=WriterConfig(spill=True).spill_budget(tmp_path))
    worker.begin(out, 32, 32)
    frames = [np.full((32, 32, 3), 20 + 25 * i, np.uint8) for i in range(8)]

    def hand_over() -> None:
        for frame in frames:
            worker.put(frame)

    producer = threading.Thread(target=hand_over, daemon=True)
    producer.start()
    producer.join(timeout=60)  # not a timing: the old code never returns from the FIFO's open
    assert not producer.is_alive(), "the producer waited on the disk"
    job = worker.finish_later()
    done = worker.wait(job)
    assert fifo.exists() and job.lag.spilled >= 1  # the disk has not answered yet: nothing waited on it
    levels = _levels(out)
    assert done.frames == len(levels) == 8
    assert np.abs(np.array(levels) - [20 + 25 * i for i in range(8)]).max() < 4, levels
    with open(fifo, "rb") as reader:  # the disk answers: the file written late is not needed, and goes
        reader.read()
    worker.close()
    assert not fifo.parent.exists()


def test_a_full_disk_during_a_spill_fails_the_episode_and_keeps_the_committed_ones(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """ENOSPC from the kernel itself: episode 1's first spilled frame's file is a link to /dev/full, whose every
    write(2) fails with ENOSPC. The episode being recorded fails with one `DiskError` (``write.disk``), the frames
    it had are not half-committed, the spill folder goes, and lerobot loads episode 0 frame-exact."""
    root = tmp_path / "ds"
    config = WriterConfig(queue_size=1, spill=True, video=H264)
    writer, states = write_dataset(root, [3], config=config, close=False)
    spill_dir = writer.pending_video("cam").with_name(writer.pending_video("cam").name + ".spill")
    spill_dir.mkdir()
    (spill_dir / ".000000.npy.tmp").symlink_to("/dev/full")
    monkeypatch.setenv(ENCODE_DELAY_ENV, "0.2")
    bridge = DatasetBridge(unit_schema(), [writer], first_episode=1)
    with pytest.raises(DiskError) as err:
        write_episodes(bridge, [3, 30], first=1)
    bridge.close()
    assert err.value.code == "write.disk" and "no space left on device" in str(err.value), err.value
    assert "spilling camera cam's frames" in str(err.value)
    check_loads(root, [3], states)
    assert not [p for p in root.rglob("*") if "spill" in p.name or p.name.endswith(".tmp")]


def test_the_spill_cap_fails_the_episode_with_its_own_code(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """`spill_limit_mb` caps the spilled bytes (default: half the disk's free space); a spill beyond it is the
    episode's end with ``write.disk.spill``, naming the cap, and leaves no spilled file behind."""
    default = WriterConfig(spill=True).spill_budget(tmp_path)
    assert default is not None
    assert default.limit == pytest.approx(shutil.disk_usage(tmp_path).free / 2, rel=0.05)
    assert WriterConfig().spill_budget(tmp_path) is None  # no spill, no budget
    monkeypatch.setenv(ENCODE_DELAY_ENV, "0.2")
    budget = WriterConfig(spill=True, spill_limit_mb=0.01).spill_budget(tmp_path)  # 10 KB: three 32x32 frames
    worker = EncoderWorker("cam", H264, fps=10, queue_size=1, spill=budget)
    worker.begin(tmp_path / "ep.mp4", 32, 32)
    with pytest.raises(DiskError) as err:
        for i in range(40):
            worker.put(np.full((32, 32, 3), i, np.uint8))
    assert err.value.code == "write.disk.spill" and "over the spill cap of 0.01 MB" in str(err.value), err.value
    worker.abort()
    worker.close()
    assert not list(tmp_path.rglob("*.spill"))
