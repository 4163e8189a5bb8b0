"""What the array sources (HDF5, Zarr, RLDS: `formats.episodic`) share as source kinds: `info` lists their
arrays, `--print-mapping` prints their layout's starting mapping, a conversion maps array keys to features
(`--mapping`, else the starting mapping) and runs `convert_arrays` (or its `--workers` split over `blocks`).
A kind of them says only how it is detected, split and reopened, and its layout's starting mapping."""

from __future__ import annotations

from abc import abstractmethod
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any, ClassVar

from openral_data.convert.kinds.base import Description, Plan, ProgressFn, Request, SourceKind, StartingMapping
from openral_data.errors import DatasetError, UsageError
from openral_data.formats.episodic import ArrayEpisode, ArraySource

if TYPE_CHECKING:
    from openral_data.convert.array_mapping import Guess
    from openral_data.convert.kinds.base import Parallel
    from openral_data.convert.summary import ConvertSummary
    from openral_data.schemas.mapping import Mapping

LayoutMapping = tuple[dict[str, Any], list["Guess"]]


def with_first[T](source: ArraySource, fn: Callable[[ArrayEpisode], T]) -> T:
    """`fn` of the source's first episode (the source closed again after)."""
    episodes = source.episodes()
    try:
        first = next(iter(episodes), None)
        if first is None:
            raise DatasetError(f"{source.path}: no episodes ({source.layout} layout)", code="dataset.source.empty")
        return fn(first)
    finally:
        close = getattr(episodes, "close", None)
        if close is not None:
            close()
        source.close()


class ArrayKind(SourceKind[ArraySource]):
    layouts: ClassVar[tuple[str, ...]]  # the `ArraySource.layout`s this kind opens
    usual_fps: ClassVar[tuple[int, str]] = (10, "a placeholder")  # --print-mapping's guess for a source without

    @abstractmethod
    def layout_mapping(self, source: ArraySource, first: ArrayEpisode) -> LayoutMapping:
        """The layout's starting mapping (plain data, fps left out) and the guesses in it."""

    def describe(self, handle: ArraySource) -> Description:
        from openral_data.convert.discover import describe_arrays

        return describe_arrays(handle)

    def blocks(self, handle: ArraySource) -> list[Path]:
        return [handle.path]

    def _starting(self, source: ArraySource, first: ArrayEpisode, fps: int | None) -> LayoutMapping:
        out, guesses = self.layout_mapping(source, first)
        rate = source.fps if fps is None else fps
        return {"fps": round(rate) if rate is not None else None, **out}, guesses

    def starting_mapping(self, handle: ArraySource, fps: int | None) -> StartingMapping:
        from openral_data.convert.array_mapping import mapping_yaml, with_fps_guess

        data, guesses = with_first(handle, lambda first: self._starting(handle, first, fps))
        with_fps_guess(data, guesses, *self.usual_fps)
        mapping = {k: v for k, v in data.items() if v not in (None, {})}
        why = {g.key: g.why for g in guesses}
        return StartingMapping(handle.path, handle.layout, mapping, why, mapping_yaml(data, guesses, handle.layout))

    def mapping(self, source: ArraySource, given: Path | Mapping | None, fps: int | None) -> Mapping:
        """The mapping a conversion of `source` uses, its vector parts named (widths from the first episode)."""
        from openral_data.convert.array_mapping import mapping_of
        from openral_data.convert.from_arrays import named
        from openral_data.schemas.mapping import load_mapping

        if given is not None and fps is not None:
            raise UsageError("--fps with --mapping: set fps in the mapping")
        loaded = load_mapping(given) if isinstance(given, Path) else given

        def build(first: ArrayEpisode) -> Mapping:
            mapping = loaded or mapping_of(self._starting(source, first, fps)[0], str(source.path))
            return named(mapping, first, str(source.path))

        return with_first(source, build)

    def plan(self, handle: ArraySource, dst: Path, request: Request) -> Plan:
        if request.episodes is not None:
            raise UsageError(
                f"--episodes selects episodes of a LeRobot dataset; SRC is an array source ({handle.layout})"
            )
        mapping = self.mapping(handle, request.mapping, request.fps)
        return ArrayPlan(self, handle, dst, mapping, request)


class ArrayPlan(Plan):
    unit = "steps"

    def __init__(self, kind: ArrayKind, source: ArraySource, dst: Path, mapping: Mapping, request: Request) -> None:
        super().__init__(source.path, dst)
        self.kind = kind
        self.source = source
        self.mapping = mapping
        self.request = request

    @property
    def parallel(self) -> Parallel | None:
        return self.request.parallel

    def run(self, progress: ProgressFn | None = None) -> ConvertSummary:
        from openral_data.convert.from_arrays import convert_arrays
        from openral_data.convert.parallel import convert_arrays_parallel

        video, p = self.request.video, self.parallel
        if p is None:
            return convert_arrays(self.source, self.dst, self.mapping, video=video, progress=progress)
        return convert_arrays_parallel(
            self.source, self.dst, self.mapping, p.workers, executor=p.executor, address=p.address, video=video,
            progress=progress, files=self.kind.blocks(self.source), reopen=self.kind.open_block,
        )  # fmt: skip

    def to_json(self, summary: ConvertSummary) -> dict[str, Any]:
        workers = (self.parallel.workers, self.parallel.executor) if self.parallel is not None else (1, None)
        return summary.to_json(self.mapping, *workers)

    def rows(self, summary: ConvertSummary) -> list[tuple[str, str]]:
        from openral_data.convert.kinds.report import array_rows

        return array_rows(self.source, self.dst, self.mapping, summary, self.parallel)
