"""What a source holds, before anything is converted (`info SRC`): a bag's topics, or an array source's keys.

Bags (a ROS 1 ``.bag``, a rosbag2 folder, a plain ``.mcap``, or a folder of those): every topic with its message
type, message count and mean rate, and the recording's span, read from the bags' indexes (no message is decoded).
Array sources: the layout, the episodes and their steps, and every per-step array's dtype, shape and encoding,
found by the source kinds `convert` uses too (`convert.kinds`: each returns its source, None when the path is not
of its kind, or raises `DatasetError` when it is but is malformed) and read through the episodic protocol. Each
prints as `info SRC --json` (`to_json`) or as rows under SRC (`rows`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from openral_data.convert.sources import BAG_READ_ERRORS, find_bags, open_reader
from openral_data.errors import BagError
from openral_data.formats.episodic import ArraySource, ArraySpec

MAX_LANGUAGES = 1000  # distinct task texts listed (an OXE dataset may give every episode its own)


@dataclass
class TopicInfo:
    topic: str
    msgtype: str
    messages: int = 0
    seconds: float = 0.0  # the spans of the bags that hold the topic, summed

    @property
    def rate(self) -> float | None:
        """Mean messages a second over the bags that hold the topic (None for a span of zero)."""
        return self.messages / self.seconds if self.seconds > 0 else None


@dataclass
class BagInfo:
    """The bags of a source, their topics summed over all of them."""

    path: Path
    bags: list[Path]
    duration: float  # seconds, summed over the bags
    topics: dict[str, TopicInfo] = field(default_factory=dict)

    def to_json(self) -> dict[str, Any]:
        return {
            "source": str(self.path),
            "kind": "bag",
            "bags": [str(b) for b in self.bags],
            "duration_s": round(self.duration, 6),
            "topics": [
                {"topic": t.topic, "type": t.msgtype, "messages": t.messages, "rate_hz": _round(t.rate)}
                for t in self.topics.values()
            ],
        }

    def rows(self) -> list[tuple[str, str]]:
        rows = [("bags", str(len(self.bags))), ("duration", f"{self.duration:.2f} s")]
        for t in self.topics.values():
            rate = f"{t.rate:.2f} Hz" if t.rate is not None else "-"
            rows.append((t.topic, f"{t.msgtype}, {t.messages} msgs, {rate}"))
        return rows


def describe_bags(src: Path) -> BagInfo:
    """The topics of every bag in `src`, from the bags' indexes."""
    bags = find_bags(src)
    info = BagInfo(src, bags, 0.0)
    for bag in bags:
        reader = open_reader(bag)
        try:
            seconds = reader.duration / 1e9 if reader.connections else 0.0
            info.duration += seconds
            for conn in reader.connections:
                topic = info.topics.setdefault(conn.topic, TopicInfo(conn.topic, conn.msgtype))
                if topic.msgtype != conn.msgtype:
                    raise BagError(f"{bag}: {conn.topic}: carries {conn.msgtype}, another bag {topic.msgtype}",
                                   code="bag.type")  # fmt: skip
                topic.messages += int(conn.msgcount)
                topic.seconds += seconds
        except BAG_READ_ERRORS as exc:
            raise BagError(f"{bag}: cannot read bag: {exc}", code="bag.invalid") from None
        finally:
            reader.close()
    return info


@dataclass
class ArrayInfo:
    """An array source's layout, episodes, steps, per-step arrays and task texts."""

    path: Path
    layout: str
    fps: float | None
    episodes: int
    steps: int
    arrays: list[ArraySpec]
    languages: list[str]
    ignored: dict[str, str] = field(default_factory=dict)  # datasets that are not per-step arrays (key -> why)

    def to_json(self) -> dict[str, Any]:
        return {
            "source": str(self.path),
            "kind": "arrays",
            "layout": self.layout,
            "fps": self.fps,
            "episodes": self.episodes,
            "steps": self.steps,
            "arrays": [
                {"key": a.key, "dtype": a.dtype, "shape": list(a.shape), "encoding": a.encoding} for a in self.arrays
            ],
            "languages": self.languages,
            "ignored": self.ignored,
        }

    def rows(self) -> list[tuple[str, str]]:
        fps = f"{self.fps:g}" if self.fps is not None else "not stored (convert --fps N or the mapping)"
        more = len(self.languages) - 5
        languages = "; ".join(self.languages[:5]) + (f" (+{more} more)" if more > 0 else "")
        rows = [("layout", self.layout), ("episodes", str(self.episodes)), ("steps", str(self.steps)), ("fps", fps)]
        rows += [
            (a.key, f"{a.dtype} {list(a.shape)}" + ("" if a.encoding == "raw" else f" ({a.encoding})"))
            for a in self.arrays
        ]
        rows += [(key, f"ignored: {why}") for key, why in self.ignored.items()]
        rows.append(("tasks", languages or "-"))
        return rows


def describe_arrays(source: ArraySource) -> ArrayInfo:
    """Every episode opened in turn (one at a time) and counted; the arrays are the first episode's (an episode
    whose arrays differ from it is a `DatasetError`)."""
    from openral_data.errors import DatasetError

    info = ArrayInfo(source.path, source.layout, source.fps, 0, 0, [], [])
    try:
        for episode in source.episodes():
            specs = episode.specs()
            if info.episodes == 0:
                info.arrays = specs
            elif specs != info.arrays:
                raise DatasetError(f"{source.path}: episode {episode.name}: its arrays differ from the first episode's",
                                   code="dataset.invalid")  # fmt: skip
            for key, why in episode.meta.ignored.items():
                info.ignored.setdefault(key, why)
            info.episodes += 1
            info.steps += episode.length
            language = episode.meta.language
            if language and language not in info.languages and len(info.languages) < MAX_LANGUAGES:
                info.languages.append(language)
    finally:
        source.close()
    return info


def _round(value: float | None) -> float | None:
    return None if value is None else round(value, 3)
