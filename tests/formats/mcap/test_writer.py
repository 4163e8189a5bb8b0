"""The MCAP sink on its own: backpressure instead of drops, failures surface, nothing half-written is visible."""

from __future__ import annotations

import threading
import time
from pathlib import Path

import numpy as np
import numpy.typing as npt
import pytest

from openral_data.errors import DiskError, OutputExists, WriteError
from openral_data.formats.mcap import McapConfig, McapSink, finished_bags
from openral_data.formats.mcap import writer as mcap_writer
from openral_data.formats.mcap.messages import MessageFactory
from openral_data.types import CameraShape, DatasetSchema, EpisodeStart, Frame
from tests.support.faults import Faults, inject
from tests.support.mcap import check_bag
from tests.support.timing import TIMED

pytestmark = TIMED

SCHEMA = DatasetSchema(
    fps=10, state_names=("a", "b"), action_names=("x",), cameras={"cam": CameraShape(16, 16)}, robot_type="r"
)


def _frame(t: int) -> Frame:
    img = np.full((16, 16, 3), t, np.uint8)
    return Frame(
        state=np.array([t, 0], np.float32), action=np.array([t], np.float32), images={"cam": img},
        task="t", reward=0.0, done=False, success=False, timestamp=t / 10,
    )  # fmt: skip


def test_a_stalled_encoder_blocks_the_producer_and_loses_nothing(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    gate = threading.Event()
    real = MessageFactory.compress

    def stalled(self: MessageFactory, rgb: npt.NDArray[np.uint8]) -> bytes:
        gate.wait()
        return real(self, rgb)

    monkeypatch.setattr(MessageFactory, "compress", stalled)
    sink = McapSink(tmp_path / "m", SCHEMA, McapConfig(queue_size=4, image_format="png", encoder_threads=2))
    sink.begin_episode(EpisodeStart(seed=0, initial_state={}))
    added = 0

    def produce() -> None:
        nonlocal added
        for t in range(50):
            sink.add_frame(_frame(t))
            added += 1

    producer = threading.Thread(target=produce)
    producer.start()
    time.sleep(1.0)
    assert producer.is_alive() and added == 4  # 4 frames may wait for their images; the 5th add_frame blocks
    gate.set()
    producer.join(timeout=30)
    assert added == 50
    record = sink.end_episode(True)
    sink.close()
    assert record.length == 50
    topics = check_bag(finished_bags(tmp_path / "m")[0])
    assert [int(js.position[0]) for _, js in topics["/joint_states"]] == list(range(50))
    assert len(topics["/camera/cam/image/compressed"]) == 50


@pytest.mark.parametrize("threads", [0, 1])
def test_a_failing_write_fails_the_episode_and_leaves_no_bag(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, threads: int
) -> None:
    sink = McapSink(tmp_path / "m", SCHEMA, McapConfig(encoder_threads=threads))
    sink.begin_episode(EpisodeStart(seed=0, initial_state={}))
    sink.add_frame(_frame(0))
    assert sink.end_episode(True).length == 1

    def broken(self: mcap_writer.EpisodeBag, frame: Frame, encoded: dict[str, bytes]) -> None:
        raise OSError("disk full")

    monkeypatch.setattr(mcap_writer.EpisodeBag, "write_frame", broken)
    sink.begin_episode(EpisodeStart(seed=1, initial_state={}))
    # the code says the write failed; the wording carries the episode and the cause (disk full), matched too
    with pytest.raises(WriteError, match="episode 1: MCAP write failed: disk full") as excinfo:
        # in the caller's thread the write happens in add_frame; with encoder threads at end_episode
        sink.add_frame(_frame(0))
        sink.end_episode(True)
    assert excinfo.value.code == "write"
    sink.close()
    assert [p.name for p in finished_bags(tmp_path / "m")] == ["episode_000000"]
    assert not (tmp_path / "m" / ".partial").exists()


def _episode(sink: McapSink, seed: int, faults: Faults | None = None) -> None:
    sink.begin_episode(EpisodeStart(seed=seed, initial_state={}))
    if faults is not None:
        faults.armed = True
    for t in range(3):
        sink.add_frame(_frame(t))
    sink.end_episode(True)


def test_a_full_disk_at_any_call_of_an_episode_fails_it_cleanly(tmp_path: Path) -> None:
    counted = Faults()
    with inject(counted):
        _episode(McapSink(tmp_path / "count", SCHEMA), 0, counted)
    assert {"bag message", "bag close", "fsync", "replace episode_000000"} <= set(counted.calls)
    for n in range(1, len(counted.calls) + 1):
        root = tmp_path / f"m{n}"
        sink = McapSink(root, SCHEMA)
        _episode(sink, 0)
        kept = {p: p.read_bytes() for p in sorted((root / "episode_000000").iterdir())}
        faults = Faults(fail_at=n)
        with inject(faults):  # the disk stays full, for close() too
            with pytest.raises(DiskError) as excinfo:
                _episode(sink, 1, faults)
            sink.close()  # after the failure: no second error
        assert excinfo.value.code == "write.disk"
        assert str(excinfo.value).startswith(f"{root}: no space left on device while ")
        assert {p: p.read_bytes() for p in sorted((root / "episode_000000").iterdir())} == kept
        assert not (root / ".partial").exists()
        # a complete second bag only when the failure came after its rename (a folder sync)
        assert [p.name for p in finished_bags(root)] in (["episode_000000"], ["episode_000000", "episode_000001"])


def test_refuses_to_write_into_a_non_empty_folder(tmp_path: Path) -> None:
    (tmp_path / "m").mkdir()
    (tmp_path / "m" / "notes.txt").write_text("keep")
    with pytest.raises(OutputExists) as excinfo:
        McapSink(tmp_path / "m", SCHEMA)
    assert excinfo.value.code == "output.exists"
    assert (tmp_path / "m" / "notes.txt").read_text() == "keep"


def test_discarded_episode_leaves_nothing(tmp_path: Path) -> None:
    sink = McapSink(tmp_path / "m", SCHEMA)
    sink.begin_episode(EpisodeStart(seed=0, initial_state={}))
    sink.add_frame(_frame(0))
    sink.discard_episode()
    sink.close()
    assert not (tmp_path / "m").exists()  # no finished episode: the folder it created is gone


def _one_episode(sink: McapSink, index: int | None = None) -> None:
    sink.begin_episode(EpisodeStart(seed=0, initial_state={}), index)
    sink.add_frame(_frame(0))
    sink.end_episode(True)


def test_the_sink_numbers_its_bags_from_first_index_or_the_index_it_is_handed(tmp_path: Path) -> None:
    """Nobody sets the sink's numbering from outside: a `--workers` share gives its first number when the sink is
    built, an export keeping the source's numbers hands each episode's with `begin_episode`."""
    sink = McapSink(tmp_path / "share", SCHEMA, first_index=5)
    _one_episode(sink)
    _one_episode(sink)
    sink.close()
    assert [p.name for p in finished_bags(tmp_path / "share")] == ["episode_000005", "episode_000006"]
    sink = McapSink(tmp_path / "export", SCHEMA)
    _one_episode(sink, 3)
    _one_episode(sink, 7)
    _one_episode(sink)  # no index: after the episodes written so far
    sink.close()
    names = [p.name for p in finished_bags(tmp_path / "export")]
    assert names == ["episode_000002", "episode_000003", "episode_000007"]
