"""The bridge rejects every class of contract violation with a message naming what and where."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

# ContractViolation raises are matched by message on purpose: the file and field it names are the point
from openral_data.errors import ContractViolation
from openral_data.runtime.bridge import DatasetBridge
from openral_data.types import CameraShape, DatasetSchema, EpisodeRecord, EpisodeStart, Frame, Observation

SCHEMA = DatasetSchema(
    fps=10,
    state_names=("a", "b", "c"),
    action_names=("x", "y"),
    cameras={"front": CameraShape(4, 6), "wrist": CameraShape(2, 2)},
    robot_type="test",
)


class RecordingSink:
    """A real in-memory sink: keeps what it is given, so the tests can see exactly what passed the bridge."""

    def __init__(self) -> None:
        self.frames: list[Frame] = []
        self.starts: list[EpisodeStart] = []
        self.ended: list[bool | None] = []
        self.discarded = 0
        self.closed = False

    def begin_episode(self, start: EpisodeStart) -> None:
        self.starts.append(start)

    def add_frame(self, frame: Frame) -> None:
        self.frames.append(frame)

    def annotate_episode(self, info: dict[str, Any]) -> None: ...

    def end_episode(self, success: bool | None) -> EpisodeRecord:
        self.ended.append(success)
        return EpisodeRecord(len(self.ended) - 1, len(self.frames), success, self.starts[-1].seed)

    def discard_episode(self) -> None:
        self.discarded += 1

    def close(self) -> None:
        self.closed = True


def obs(**over: Any) -> Observation:
    images = {"front": np.zeros((4, 6, 3), np.uint8), "wrist": np.zeros((2, 2, 3), np.uint8)}
    base: dict[str, Any] = {"images": images, "state": np.zeros(3, np.float32), "task": "t"}
    base.update(over)
    return Observation(**base)


ACTION = np.zeros(2, np.float32)


@pytest.fixture
def bridge() -> tuple[DatasetBridge, RecordingSink]:
    sink = RecordingSink()
    b = DatasetBridge(SCHEMA, [sink])
    b.begin_episode(seed=7, initial_state={"k": 1})
    return b, sink


def add(b: DatasetBridge, o: Observation, action: Any = ACTION) -> None:
    b.add_step(o, action, reward=0.0, done=False, success=False)


def test_valid_frames_pass_and_are_copied(bridge: tuple[DatasetBridge, RecordingSink]) -> None:
    b, sink = bridge
    o = obs()
    add(b, o)
    o.state[0] = 99.0  # a producer reusing its buffer must not change what was recorded
    o.images["front"][0, 0, 0] = 255
    assert sink.frames[0].state[0] == 0.0 and sink.frames[0].images["front"][0, 0, 0] == 0
    assert b.end_episode(True)[0].seed == 7
    assert sink.ended == [True] and sink.starts[0].initial_state == {"k": 1}


@pytest.mark.parametrize(
    ("observation", "action", "message"),
    [
        (
            obs(state=np.zeros(4, np.float32)),
            ACTION,
            r"step 0: observation.state: expected float32\[3\], got float32\[4\]",
        ),
        (obs(state=np.zeros(3, np.float64)), ACTION, r"observation.state: expected float32\[3\], got float64\[3\]"),
        (obs(state=[0.0, 0.0, 0.0]), ACTION, r"observation.state: expected a float32 numpy array, got list"),
        (
            obs(state=np.array([0, np.nan, 0], np.float32)),
            ACTION,
            r"observation.state: non-finite values at dims \[1\]",
        ),
        (obs(), np.array([np.inf, 0], np.float32), r"action: non-finite values at dims \[0\]"),
        (obs(), np.zeros(3, np.float32), r"action: expected float32\[2\], got float32\[3\]"),
        (obs(), np.zeros(2, np.int64), r"action: expected float32\[2\], got int64\[2\]"),
        (
            obs(images={"front": np.zeros((4, 6, 3), np.float32), "wrist": np.zeros((2, 2, 3), np.uint8)}),
            ACTION,
            r"images.front: expected uint8\[4, 6, 3\] \(HWC\), got float32\[4, 6, 3\]",
        ),
        (
            obs(images={"front": np.zeros((3, 4, 6), np.uint8), "wrist": np.zeros((2, 2, 3), np.uint8)}),
            ACTION,
            r"images.front: expected uint8\[4, 6, 3\] \(HWC\), got uint8\[3, 4, 6\]",
        ),
        (obs(images={"front": np.zeros((4, 6, 3), np.uint8)}), ACTION, r"missing \['wrist'\]"),
        (
            obs(images={**obs().images, "extra": np.zeros((2, 2, 3), np.uint8)}),
            ACTION,
            r"undeclared \['extra'\]",
        ),
        (obs(task=""), ACTION, r"task: expected a non-empty string"),
        (obs(transforms={"hand": np.zeros(6)}), ACTION, r"transforms.hand: expected 7 finite numbers"),
        (obs(transforms={"hand": np.full(7, np.nan)}), ACTION, r"transforms.hand: expected 7 finite numbers"),
    ],
)
def test_violations_are_rejected(
    bridge: tuple[DatasetBridge, RecordingSink], observation: Observation, action: Any, message: str
) -> None:
    b, sink = bridge
    with pytest.raises(ContractViolation, match=message):
        add(b, observation, action)
    assert sink.frames == []  # nothing invalid reaches a sink


def test_violation_message_says_where(bridge: tuple[DatasetBridge, RecordingSink]) -> None:
    b, _ = bridge
    add(b, obs())
    add(b, obs())
    with pytest.raises(ContractViolation, match=r"^episode 0 step 2: observation.state"):
        add(b, obs(state=np.zeros(1, np.float32)))


def test_check_action_before_the_producer_sees_it(bridge: tuple[DatasetBridge, RecordingSink]) -> None:
    b, _ = bridge
    b.check_action(ACTION)
    with pytest.raises(ContractViolation, match="action"):
        b.check_action(np.zeros(5, np.float32))


def test_empty_episode_is_refused_and_discarded(bridge: tuple[DatasetBridge, RecordingSink]) -> None:
    b, sink = bridge
    with pytest.raises(ContractViolation, match="at least one frame"):
        b.end_episode(True)
    assert sink.discarded == 1 and sink.ended == []


def test_close_discards_episode_in_flight(bridge: tuple[DatasetBridge, RecordingSink]) -> None:
    b, sink = bridge
    add(b, obs())
    b.close()
    assert sink.discarded == 1 and sink.closed and sink.ended == []


class _Timestamps:
    def __init__(self) -> None:
        self.got: list[float] = []

    def begin_episode(self, start: EpisodeStart) -> None: ...

    def add_frame(self, frame: Frame) -> None:
        self.got.append(frame.timestamp)

    def annotate_episode(self, info: dict[str, Any]) -> None: ...

    def end_episode(self, success: bool | None) -> EpisodeRecord:
        return EpisodeRecord(0, len(self.got), success, 0)

    def discard_episode(self) -> None: ...

    def close(self) -> None: ...


def test_frame_timestamps_come_from_the_producer_clock() -> None:
    sink = _Timestamps()
    bridge = DatasetBridge(DatasetSchema(10, ("s",), ("a",), {}, "r"), [sink])
    bridge.begin_episode(0, {})
    a = np.zeros(1, np.float32)
    for time in (None, 0.25, 0.25, 0.5):
        bridge.add_step(Observation({}, np.zeros(1, np.float32), "t", time), a, reward=0, done=False, success=False)
    assert sink.got == [0.0, 0.25, 0.25, 0.5]
    with pytest.raises(ContractViolation, match="non-decreasing"):
        bridge.add_step(Observation({}, np.zeros(1, np.float32), "t", 0.1), a, reward=0, done=False, success=False)


class _Verdicts(_Timestamps):
    def __init__(self) -> None:
        super().__init__()
        self.verdicts: list[object] = []

    def end_episode(self, success: bool | None) -> EpisodeRecord:
        self.verdicts.append(success)
        return EpisodeRecord(0, len(self.got), success, 0)


def test_episode_success_reaches_sinks_as_a_python_bool_or_none() -> None:
    sink = _Verdicts()
    bridge = DatasetBridge(DatasetSchema(10, ("s",), ("a",), {}, "r"), [sink])
    a = np.zeros(1, np.float32)
    for verdict in (np.True_, np.False_, None):
        bridge.begin_episode(0, {})
        bridge.add_step(Observation({}, np.zeros(1, np.float32), "t"), a, reward=0, done=True, success=False)
        bridge.end_episode(verdict)  # type: ignore[arg-type]
    assert sink.verdicts == [True, False, None]
    assert [type(v) for v in sink.verdicts[:2]] == [bool, bool]


class Watcher:
    """A FrameObserver that keeps the calls it gets, in order."""

    def __init__(self) -> None:
        self.calls: list[tuple[str, object]] = []

    def begin_episode(self, index: int, start: EpisodeStart) -> None:
        self.calls.append(("begin", (index, start.seed)))

    def add_frame(self, frame: Frame) -> None:
        self.calls.append(("frame", frame.reward))

    def end_episode(self, record: EpisodeRecord | None) -> None:
        self.calls.append(("end", None if record is None else record.length))

    def close(self) -> None:
        self.calls.append(("close", None))


def test_observers_see_validated_frames_after_the_sinks_and_each_outcome() -> None:
    sink, watcher = RecordingSink(), Watcher()
    b = DatasetBridge(SCHEMA, [sink], first_episode=4, observers=[watcher])
    b.begin_episode(seed=9, initial_state={})
    b.add_step(obs(), ACTION, reward=0.5, done=True, success=True)
    b.end_episode(True)
    b.begin_episode(seed=10, initial_state={})
    with pytest.raises(ContractViolation):  # a bad frame reaches neither the sinks nor the observers
        b.add_step(obs(state=np.zeros(2, np.float32)), ACTION, reward=1.0, done=False, success=False)
    b.add_step(obs(), ACTION, reward=2.0, done=False, success=False)
    b.close()  # the episode in flight is discarded: the observer hears None
    assert watcher.calls == [
        ("begin", (4, 9)), ("frame", 0.5), ("end", 1),
        ("begin", (5, 10)), ("frame", 2.0), ("end", None), ("close", None),
    ]  # fmt: skip
    assert len(sink.frames) == 2 and sink.closed


def test_a_bridge_without_sinks_shows_observers_complete_episodes_under_the_given_numbers() -> None:
    seen: list[EpisodeRecord | None] = []

    class Keeper(Watcher):
        def end_episode(self, record: EpisodeRecord | None) -> None:
            seen.append(record)  # the whole record

    watcher = Keeper()
    b = DatasetBridge(SCHEMA, [], observers=[watcher])
    b.begin_episode(seed=3, initial_state={}, index=2)  # a replay of recorded episode 2
    b.add_step(obs(), ACTION, reward=0.0, done=False, success=False)
    b.add_step(obs(), ACTION, reward=1.0, done=True, success=True)
    assert b.end_episode(True) == []  # nothing was written
    with pytest.raises(ContractViolation):  # still validated as a recording is
        b.begin_episode(seed=4, initial_state={}, index=5)
        b.add_step(obs(task=""), ACTION, reward=0.0, done=False, success=False)
    b.close()
    assert seen == [EpisodeRecord(index=2, length=2, success=True, seed=3), None]
    assert watcher.calls[0] == ("begin", (2, 3)) and ("begin", (5, 4)) in watcher.calls

    with pytest.raises(RuntimeError, match="bridge with sinks"):  # sinks number their episodes themselves
        DatasetBridge(SCHEMA, [RecordingSink()]).begin_episode(seed=0, initial_state={}, index=3)
