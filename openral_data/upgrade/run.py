"""`upgrade(OLD, NEW)`: a LeRobot v2.0/v2.1 dataset written again as v3.0 by lerobot 0.6.1's own converter.

The steps of lerobot's `convert_dataset_v21_to_v30` run one by one (`convert_info`, `convert_tasks`,
`convert_data`, `convert_videos`, `convert_episodes_metadata`), never its `convert_dataset`, which downloads,
moves the input aside and pushes: here they read a fixed-up v2.1 copy of OLD's metadata beside links to OLD's
files (`source.write_source`, with the per-episode statistics OLD lacks computed by `episode_stats`), and write
NEW's hidden staging folder (`formats.staging`), renamed to NEW once complete. OLD is only read; a failure or a
kill leaves NEW absent; nothing touches the network (the steps take local folders). The `datasets` cache lerobot's
episodes step fills and the temporary files of its video step are pointed into the staging folder.
"""

from __future__ import annotations

import importlib
import io
import logging
import shutil
import tempfile
from collections.abc import Callable, Iterator
from contextlib import contextmanager, redirect_stderr
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType
from typing import Any

from openral_data.errors import CompatibilityError, DatasetError, UsageError, install_hint
from openral_data.formats.lerobot_v3.loadable import datasets_cache
from openral_data.formats.parquetfile import num_rows
from openral_data.formats.staging import Staging, check_new_output
from openral_data.formats.write_errors import disk_errors
from openral_data.upgrade.columns import FixedData, fixed_data
from openral_data.upgrade.episode_stats import episode_stats, missing_stats
from openral_data.upgrade.legacy import Legacy, check_videos, read_legacy
from openral_data.upgrade.source import write_source

SCRATCH = ".upgrade"  # inside the staging folder, removed before it is published
Say = Callable[[str], None]


@dataclass(frozen=True)
class UpgradeResult:
    out: Path
    version: str  # OLD's codebase_version
    episodes: int
    frames: int
    computed: list[str]  # features whose per-episode statistics were computed (absent from OLD, or rewritten)
    rewritten: list[str]  # index columns set as lerobot writes them (`columns.fixed_data`)


def upgrade(old: Path, new: Path, on_stage: Say | None = None) -> UpgradeResult:
    """Write NEW (LeRobot v3.0) from OLD (v2.0/v2.1); `on_stage(text)` is told what each stage is about to do."""
    say = on_stage or (lambda _text: None)
    check_new_output(new)
    if new.resolve().is_relative_to(old.resolve()):
        raise UsageError(f"{new}: NEW is inside OLD ({old}); upgrade never writes into OLD")
    converter = _converter()
    legacy = read_legacy(old)  # before the first stage line: a refused OLD is one line, nothing before it
    say(f"read {old}: LeRobot {legacy.version}, {len(legacy.episodes)} episode(s)")
    lengths = [num_rows(path) for path in legacy.data]
    check_videos(legacy, lengths)
    staged = Staging(new, "openral-data upgrade")
    with disk_errors(new, "writing the upgraded dataset"), staged as out:
        scratch = out / SCRATCH
        data = fixed_data(legacy, lengths, scratch / "rewritten")
        _say_fixes(legacy, data, say)
        stats, computed = _complete_stats(legacy, data, scratch / "frames", say)
        write_source(legacy, data.paths, stats, lengths, scratch / "source")
        _convert(converter, old, scratch, out, say)
        shutil.rmtree(scratch)
        staged.publish()
    return UpgradeResult(new, legacy.version, len(legacy.episodes), sum(lengths), computed, data.rewritten)


def _converter() -> ModuleType:
    """lerobot's v2.1 -> v3.0 converter module, imported only now (it needs lerobot's `dataset` extra)."""
    try:
        return importlib.import_module("lerobot.scripts.convert_dataset_v21_to_v30")
    except ImportError as exc:
        raise CompatibilityError(
            f"upgrade: lerobot's converter is not importable ({exc.name or exc} missing): needs the 'lerobot' extra: "
            f"{install_hint('lerobot')}"
        ) from None


def _say_fixes(legacy: Legacy, data: FixedData, say: Say) -> None:
    if legacy.numbers != list(range(len(legacy.numbers))):
        shown = ", ".join(str(n) for n in legacy.numbers[:5]) + (", …" if len(legacy.numbers) > 5 else "")
        say(f"renumbering episodes {shown} as 0..{len(legacy.numbers) - 1}")
    if data.declared:
        say(f"declaring lerobot's default feature(s) {', '.join(data.declared)} that info.json lacks")
    if data.rewritten:
        say(f"rewriting {', '.join(data.rewritten)} of {len(data.columns)} episode(s) as lerobot writes them")
    if data.moved_s:
        say(f"timestamps put on the video's 1/fps grid (frame t at t / fps): moved by up to {data.moved_s:.4f} s")


def _complete_stats(
    legacy: Legacy, data: FixedData, scratch: Path, say: Say
) -> tuple[dict[int, dict[str, Any]], list[str]]:
    """Every episode's statistics: OLD's, with what it lacks or what was rewritten computed (`episode_stats`)."""
    stats: dict[int, dict[str, Any]] = {}
    computed: set[str] = set()
    for e in range(len(legacy.episodes)):
        have = dict((legacy.stats or {}).get(e, {}))
        keys = missing_stats(legacy, e, data.columns.get(e, []))
        if keys:
            if not computed:
                say(f"computing the per-episode statistics OLD lacks ({', '.join(keys)} of episode {e}, ...)")
            have.update(episode_stats(legacy, e, keys, data.paths[e], scratch / f"episode-{e}"))
            shutil.rmtree(scratch / f"episode-{e}", ignore_errors=True)
            computed.update(keys)
        stats[e] = have
    return stats, sorted(computed)


def _convert(converter: ModuleType, old: Path, scratch: Path, out: Path, say: Say) -> None:
    """lerobot's conversion steps from `scratch/source` into `out`; a failure of theirs is one line."""
    import pyarrow as pa
    from datasets.exceptions import DatasetsError
    from lerobot.datasets.utils import DEFAULT_DATA_FILE_SIZE_IN_MB, DEFAULT_VIDEO_FILE_SIZE_IN_MB

    src = scratch / "source"
    try:
        say("converting info.json and tasks")
        with _quiet():
            converter.convert_info(src, out, DEFAULT_DATA_FILE_SIZE_IN_MB, DEFAULT_VIDEO_FILE_SIZE_IN_MB)
            converter.convert_tasks(src, out)
        say("converting data files")
        with _quiet():
            episodes = converter.convert_data(src, out, DEFAULT_DATA_FILE_SIZE_IN_MB)
        say("concatenating videos")
        with _quiet(), _temp_files_in(scratch / "tmp"):
            videos = converter.convert_videos(src, out, DEFAULT_VIDEO_FILE_SIZE_IN_MB)
        say("writing episodes metadata and stats")
        with datasets_cache(scratch / "datasets-cache"), _quiet():
            converter.convert_episodes_metadata(src, out, episodes, videos)
    except (ValueError, KeyError, TypeError, IndexError, RuntimeError, pa.ArrowException, DatasetsError) as exc:
        cause = exc.__cause__ if isinstance(exc, DatasetsError) and exc.__cause__ is not None else exc
        raise DatasetError(f"{old}: lerobot's converter failed: {_first_line(cause)}", code="dataset.invalid") from None


@contextmanager
def _temp_files_in(folder: Path) -> Iterator[None]:
    """lerobot's video concatenation writes its ffconcat list and its mp4 through `tempfile`: into `folder` (in the
    staging folder: a killed run leaves nothing in the system's temp folder, and the mp4 is renamed, not copied)."""
    folder.mkdir(parents=True, exist_ok=True)
    before = tempfile.tempdir
    tempfile.tempdir = str(folder)
    try:
        yield
    finally:
        tempfile.tempdir = before


@contextmanager
def _quiet() -> Iterator[None]:
    """lerobot's own progress bars (tqdm, `datasets`: written to `sys.stderr`) swallowed, and its expected warning
    about info.json's v2 fields: the command reports its stages itself."""
    logger = logging.getLogger("lerobot")
    level = logger.level
    logger.setLevel(logging.ERROR)
    try:
        with redirect_stderr(io.StringIO()):
            yield
    finally:
        logger.setLevel(level)


def _first_line(exc: BaseException) -> str:
    return (str(exc).splitlines() or [type(exc).__name__])[0]
