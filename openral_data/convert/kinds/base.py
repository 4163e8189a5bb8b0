"""What every source kind declares (`SourceKind`), and what a conversion is asked for (`Request`) and becomes
(`Plan`). The kinds themselves and the one order they are tried in are in `convert.kinds` (its `__init__`)."""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, ClassVar, Protocol

from openral_data.errors import UsageError

if TYPE_CHECKING:
    from openral_data.convert.summary import ConvertSummary
    from openral_data.convert.to_mcap import ExportSummary
    from openral_data.formats.lerobot_v3.encoder import VideoSettings
    from openral_data.schemas.mapping import Mapping

ProgressFn = Callable[[int, int], None]  # (done, total) in the plan's `unit`


@dataclass(frozen=True)
class Parallel:
    """`--workers N [--executor local|ray] [--address A]`: a conversion split into blocks run in N processes."""

    workers: int
    executor: str = "local"
    address: str | None = None


@dataclass(frozen=True)
class Request:
    """What a conversion is asked for, whatever SRC is; each kind refuses (one line) what does not apply to it."""

    mapping: Path | Mapping | None = None  # a mapping file or a validated mapping; None: the kind's own
    video: VideoSettings | None = None  # -> LeRobot: the encoder settings (None: the defaults)
    parallel: Parallel | None = None
    fps: int | None = None  # an array source that declares no rate
    episodes: str | None = None  # LeRobot -> MCAP: the episodes exported
    image_format: str = "jpeg"  # LeRobot -> MCAP: camera messages
    mcap_compression: str = "zstd"  # LeRobot -> MCAP: chunk compression


class Description(Protocol):
    """What `info SRC` prints: `to_json()` for `--json`, else `rows()` under the source's name."""

    def to_json(self) -> dict[str, Any]: ...

    def rows(self) -> list[tuple[str, str]]: ...


@dataclass(frozen=True)
class StartingMapping:
    """`convert SRC --print-mapping`: the mapping a conversion without `--mapping` starts from, guesses marked."""

    source: Path
    layout: str
    mapping: dict[str, Any]
    guesses: dict[str, str]  # mapping key -> why it is a guess
    text: str  # the commented YAML

    def to_json(self) -> dict[str, Any]:
        return {"source": str(self.source), "layout": self.layout, "mapping": self.mapping, "guesses": self.guesses}


class Plan(ABC):
    """A conversion checked and ready: `run` does it; `to_json`/`rows` report its summary."""

    what: ClassVar[str] = "converting"  # the progress bar's label
    done: ClassVar[str] = "converted"  # the summary's title
    unit: ClassVar[str] = "frames"  # what progress counts

    def __init__(self, src: Path, dst: Path) -> None:
        self.src = src
        self.dst = dst

    @abstractmethod
    def run(self, progress: ProgressFn | None = None) -> ConvertSummary | ExportSummary: ...

    @abstractmethod
    def to_json(self, summary: Any) -> dict[str, Any]: ...

    @abstractmethod
    def rows(self, summary: Any) -> list[tuple[str, str]]: ...


class SourceKind[H](ABC):
    """One kind of source, declared once: how it is detected (`open`: its handle, None when `path` is not of this
    kind, a one-line error when it is but is broken), how `info` describes it, how `--workers` splits it
    (`blocks`, `open_block`), its starting mapping (`--print-mapping`) and how it is read (`plan`)."""

    name: ClassVar[str]  # the registry's key
    summary: ClassVar[str]  # one line for the docs

    @abstractmethod
    def open(self, path: Path) -> H | None: ...

    @abstractmethod
    def describe(self, handle: H) -> Description: ...

    @abstractmethod
    def blocks(self, handle: H) -> list[Path]:
        """What `--workers` splits the source by (one block: it is not split)."""

    @abstractmethod
    def open_block(self, src: Path, files: list[Path]) -> H | None:
        """The part of the source `src` that `files` (some of `blocks`) hold, for one worker (None: `src` is no
        longer of this kind)."""

    @abstractmethod
    def starting_mapping(self, handle: H, fps: int | None) -> StartingMapping: ...

    @abstractmethod
    def plan(self, handle: H, dst: Path, request: Request) -> Plan: ...


def no_starting_mapping(path: Path) -> UsageError:
    """What `--print-mapping` says of a source that has no mapping (a LeRobot dataset, or no source at all)."""
    return UsageError(
        f"{path}: --print-mapping applies to bags (.bag, .mcap, rosbag2 folder, folder of bags) and array sources "
        "(HDF5, Zarr replay buffer, RLDS); this is neither"
    )
