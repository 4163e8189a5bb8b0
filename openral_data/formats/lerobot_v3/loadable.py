"""The check every command runs on a LeRobot v3 dataset it built before publishing it (`staging.Staging`):
nothing is published that lerobot 0.6.1's loader cannot load.

`check_loadable(folder, out)` looks at the staged folder `folder` (to be published as `out`):

* structure, always (parquet footers and meta files only): info.json declares lerobot's default features
  (`index`, `frame_index`, `episode_index`, `task_index`, `timestamp`: its loader and its delta windows read
  them); every data file's columns are exactly the declared non-video features (lerobot's `datasets` cast fails
  with `CastError ... column names don't match` otherwise); `meta/tasks.parquet` and the episodes table are
  there; the data files hold `total_frames` rows and the episodes table `total_episodes` rows;
* with lerobot installed (unless `OPENRAL_PUBLISH_LOAD=0`: `load_frames`), the first and last frame of every
  data file loaded by lerobot's own `LeRobotDataset` (video frames decoded with PyAV): an output lerobot refuses
  is refused here.

A failure is one line, `DatasetError` code ``dataset.unloadable``, naming `out`, the file and what is wrong;
the caller discards the staged folder, so nothing is published. A folder that is not a v3 dataset (a folder of
bags, a v2.x copy) is not this check's business.
"""

from __future__ import annotations

import contextlib
import io
import logging
import os
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager, redirect_stderr
from pathlib import Path
from typing import Any

from openral_data.errors import DatasetError
from openral_data.formats.jsonfile import read_json
from openral_data.formats.lerobot_v3 import layout
from openral_data.formats.parquetfile import num_rows, read_schema

DEFAULT_FEATURES = ("index", "frame_index", "episode_index", "task_index", "timestamp")
# OPENRAL_PUBLISH_LOAD=0 skips the frames lerobot loads (structure only): e.g. a machine without lerobot's
# `dataset` extra, or a test-suite that starts hundreds of short commands (each would import lerobot and torch)
LOAD_ENV = "OPENRAL_PUBLISH_LOAD"


def load_frames() -> bool:
    """Whether the check also loads frames with lerobot (read when the check runs: the environment decides)."""
    return os.environ.get(LOAD_ENV, "1") != "0"


def warm_up() -> None:
    """Import lerobot's loader now, as `check_loadable`'s first frame load would (torch and `datasets`: about
    4 CPU-seconds): a recording whose first episode will be checked calls this beside its scene's build, so the
    check does not stall the recording between its first two episodes. Nothing without lerobot or with
    `OPENRAL_PUBLISH_LOAD=0`."""
    if not load_frames():
        return
    with contextlib.suppress(ImportError):
        import lerobot.datasets.lerobot_dataset  # noqa: F401 - the import is the point
        import scipy.io  # noqa: F401 - `datasets` imports it on its first parquet load (patching loadmat)


def check_loadable(folder: Path, out: Path) -> None:
    """Refuse (`DatasetError`, ``dataset.unloadable``) a staged v3 dataset lerobot 0.6.1 could not load."""
    info_path = folder / layout.INFO_PATH
    if not info_path.is_file():
        return
    info = read_json(info_path)
    if not isinstance(info, dict) or not str(info.get("codebase_version", "")).startswith("v3"):
        return
    files = check_structure(folder, out, info)
    if files and load_frames():
        _load_ends(folder, out, files)


def check_structure(folder: Path, out: Path, info: dict[str, Any]) -> list[Path]:
    """The structural checks (module docstring); returns the data files, in path order."""
    features: dict[str, Any] = info.get("features") or {}
    lacking = [k for k in DEFAULT_FEATURES if k not in features]
    if lacking:
        _refuse(out, layout.INFO_PATH, f"features: lerobot's default feature(s) {', '.join(lacking)} missing")
    declared = {k for k, ft in features.items() if isinstance(ft, dict) and ft.get("dtype") != "video"}
    files = sorted(p for p in (folder / "data").glob("*/*.parquet") if not p.name.startswith("."))
    rows = 0
    for path in files:
        names = set(read_schema(path).names)
        if names != declared:
            extra, missing = sorted(names - declared), sorted(declared - names)
            said = "; ".join(
                part
                for part in (
                    f"column(s) {', '.join(extra)} not declared in info.json" if extra else "",
                    f"declared feature(s) {', '.join(missing)} not in it" if missing else "",
                )
                if part
            )
            _refuse(out, str(path.relative_to(folder)), f"columns: {said}")
        rows += num_rows(path)
    if int(info.get("total_frames") or 0) != rows:
        _refuse(out, layout.INFO_PATH, f"total_frames: {info.get('total_frames')}, the data files hold {rows} row(s)")
    if rows and not (folder / layout.TASKS_PATH).is_file():
        _refuse(out, layout.TASKS_PATH, "missing")
    episodes = sorted((folder / "meta" / "episodes").glob("*/*.parquet"))
    held = sum(num_rows(p) for p in episodes)
    if int(info.get("total_episodes") or 0) != held:
        _refuse(out, layout.INFO_PATH, f"total_episodes: {info.get('total_episodes')}, meta/episodes/ holds {held}")
    return files if rows else []


def _load_ends(folder: Path, out: Path, files: list[Path]) -> None:
    """lerobot's `LeRobotDataset` on `folder`: the first and last frame of every data file loaded."""
    try:
        from lerobot.datasets.lerobot_dataset import LeRobotDataset
    except ImportError:  # lerobot's `dataset` extra is not installed: the structural check is all there is
        return
    logger = logging.getLogger("lerobot")
    level = logger.level
    logger.setLevel(logging.ERROR)
    start = 0
    try:
        with redirect_stderr(io.StringIO()), tempfile.TemporaryDirectory() as cache, datasets_cache(Path(cache)):
            ds = LeRobotDataset("local/publish-check", root=folder, video_backend="pyav")
            for path in files:
                n = num_rows(path)
                for i in {start, start + n - 1} if n else set():
                    _load(ds, i, out, str(path.relative_to(folder)))
                start += n
    except DatasetError:
        raise
    except Exception as exc:  # noqa: BLE001 - lerobot's loader raises many kinds; each one is a refusal
        _refuse(out, "dataset", f"lerobot 0.6.1 cannot open it: {type(exc).__name__}: {_first_line(exc)}")
    finally:
        logger.setLevel(level)


@contextmanager
def datasets_cache(folder: Path) -> Iterator[None]:
    """`datasets` (lerobot's loader, its converter's episodes step) caches in `folder`, not the user's cache."""
    import datasets.config

    before = datasets.config.HF_DATASETS_CACHE
    datasets.config.HF_DATASETS_CACHE = folder
    try:
        yield
    finally:
        datasets.config.HF_DATASETS_CACHE = before


def _load(ds: Any, i: int, out: Path, where: str) -> None:
    try:
        ds[i]
    except Exception as exc:  # noqa: BLE001 - as above
        _refuse(out, where, f"lerobot 0.6.1 cannot load frame {i}: {type(exc).__name__}: {_first_line(exc)}")


def _first_line(exc: BaseException) -> str:
    return (str(exc).splitlines() or [""])[0][:200]


def _refuse(out: Path, where: str, what: str) -> None:
    raise DatasetError(
        f"{out}/{where}: {what}; not published (lerobot 0.6.1 could not load it)", code="dataset.unloadable"
    )
