"""The streaming aligner: previous/nearest sample, max staleness, unfillable frames reported, bounded buffers."""

from __future__ import annotations

import pytest

from openral_data.convert.align import AlignedFrame, Aligner

MS = 1_000_000


def run(aligner: Aligner[str], samples: list[tuple[str, int]]) -> list[AlignedFrame[str]]:
    frames: list[AlignedFrame[str]] = []
    for stream, t_ms in sorted(samples, key=lambda s: s[1]):
        frames.extend(aligner.push(stream, t_ms * MS, f"{stream}@{t_ms}"))
    frames.extend(aligner.finish())
    return frames


def test_previous_picks_latest_sample_at_or_before_each_frame() -> None:
    # 10 fps grid; state at 100 Hz, camera at 30 Hz (33 ms), both starting at 0
    samples = [("s", t) for t in range(0, 301, 10)] + [("c", t) for t in range(0, 301, 33)]
    frames = run(Aligner(["s", "c"], fps=10, method="previous", max_staleness=0.05), samples)
    assert [f.time_ns // MS for f in frames] == [0, 100, 200, 300]
    assert [f.samples for f in frames] == [
        {"s": "s@0", "c": "c@0"},
        {"s": "s@100", "c": "c@99"},
        {"s": "s@200", "c": "c@198"},
        {"s": "s@300", "c": "c@297"},
    ]


def test_nearest_may_take_a_later_sample() -> None:
    samples = [("s", t) for t in range(0, 301, 10)] + [("c", t) for t in (0, 60, 110, 190, 240, 310)]
    frames = run(Aligner(["s", "c"], fps=10, method="nearest", max_staleness=0.02), samples)
    got = [(f.time_ns // MS, None if f.samples is None else f.samples["c"]) for f in frames]
    assert got == [(0, "c@0"), (100, "c@110"), (200, "c@190"), (300, "c@310")]


def test_stale_frames_are_reported_never_filled() -> None:
    # the camera stops between 100 and 300 ms: frames at 200 cannot be filled
    samples = [("s", t) for t in range(0, 401, 10)] + [("c", t) for t in (0, 50, 100, 300, 350, 400)]
    aligner: Aligner[str] = Aligner(["s", "c"], fps=10, method="previous", max_staleness=0.06)
    frames = run(aligner, samples)
    assert [f.samples is None for f in frames] == [False, False, True, False, False]
    assert frames[2].missing == ("c",)
    assert aligner.stats.unfillable == {"c": 1}
    assert aligner.stats.frames == 5


def test_grid_starts_when_every_stream_has_a_sample() -> None:
    samples = [("s", t) for t in range(0, 201, 10)] + [("c", t) for t in (45, 145)]
    aligner: Aligner[str] = Aligner(["s", "c"], fps=10, method="previous", max_staleness=0.1)
    frames = run(aligner, samples)
    assert aligner.t0 == 45 * MS
    assert [f.time_ns // MS for f in frames] == [45, 145]
    assert aligner.stats.unused["s"] > 0  # state samples before the grid started went unused, and are counted


@pytest.mark.parametrize("method", ["previous", "nearest"])
def test_memory_is_bounded_by_the_staleness_window(method: str) -> None:
    aligner: Aligner[str] = Aligner(["s", "c"], fps=20, method=method, max_staleness=0.05)  # type: ignore[arg-type]
    most = 0
    for t in range(0, 60_000, 2):  # one minute, a sample every 2 ms on each stream
        for s in ("s", "c"):
            list(aligner.push(s, t * MS, "x"))
        most = max(most, *(len(b) for b in aligner._buf.values()))
    assert aligner.stats.frames > 1000
    assert most <= 2 * 50 // 2 + 30  # samples of about one staleness window (+ a frame period), not a minute
