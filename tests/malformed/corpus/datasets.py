"""A damaged dataset, read by each command that reads it; damaged replay results, read by stats and view
--results; doctor --repair on something that is not a dataset folder."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

from tests.malformed.corpus.cases import case
from tests.support.malformed import Workspace

DATA = "data/chunk-000/file-000.parquet"
EPISODES = "meta/episodes/chunk-000/file-000.parquet"
VIDEO = "videos/observation.images.front/chunk-000/file-000.mp4"


def _info(w: Workspace, ds: Path, **changes: Any) -> None:
    import json

    info = json.loads((ds / "meta/info.json").read_text())
    for key, value in changes.items():
        if value is ...:
            del info[key]
        else:
            info[key] = value
    (ds / "meta/info.json").write_text(json.dumps(info))


def _features(ds: Path) -> dict[str, Any]:
    import json

    features: dict[str, Any] = json.loads((ds / "meta/info.json").read_text())["features"]
    return features


def _to_folder(path: Path) -> None:
    path.unlink()
    path.mkdir()


def _cut(path: Path, keep: float) -> None:
    data = path.read_bytes()
    path.write_bytes(data[: int(len(data) * keep)])


# damage id -> (what it does to the copy, regex of the file the error must name)
DAMAGE: dict[str, tuple[Callable[[Workspace, Path], object], str]] = {
    "info-not-utf8": (lambda w, d: (d / "meta/info.json").write_bytes(b'{"fps": "\xff"}'), r"info\.json"),
    "info-invalid-json": (lambda w, d: (d / "meta/info.json").write_text("{fps: 20"), r"info\.json"),
    "info-empty": (lambda w, d: (d / "meta/info.json").write_bytes(b""), r"info\.json"),
    "info-list": (lambda w, d: (d / "meta/info.json").write_text("[1, 2]"), r"info\.json"),
    "info-directory": (lambda w, d: _to_folder(d / "meta/info.json"), r"info\.json"),
    "info-fps-0": (lambda w, d: _info(w, d, fps=0), r"info\.json.*fps"),
    "info-fps-string": (lambda w, d: _info(w, d, fps="fast"), r"info\.json.*fps"),
    "info-fps-missing": (lambda w, d: _info(w, d, fps=...), r"info\.json.*fps"),
    "info-features-list": (lambda w, d: _info(w, d, features=["action"]), r"info\.json.*features"),
    "info-features-missing": (lambda w, d: _info(w, d, features=...), r"info\.json.*features"),
    "episodes-garbage": (lambda w, d: (d / EPISODES).write_bytes(b"PAR1 not really PAR1"), r"meta/episodes/"),
    "episodes-empty": (lambda w, d: (d / EPISODES).write_bytes(b""), r"meta/episodes/"),
    "episodes-truncated": (lambda w, d: _cut(d / EPISODES, 0.5), r"meta/episodes/"),
    "episodes-folder": (lambda w, d: _to_folder(d / EPISODES), r"meta/episodes/"),
    "tasks-garbage": (lambda w, d: (d / "meta/tasks.parquet").write_bytes(b"\x00" * 64), r"tasks\.parquet"),
    "tasks-missing": (lambda w, d: (d / "meta/tasks.parquet").unlink(), r"tasks\.parquet"),
    "data-garbage": (lambda w, d: (d / DATA).write_bytes(b"garbage" * 10), r"data/chunk-000/file-000\.parquet"),
    "data-empty": (lambda w, d: (d / DATA).write_bytes(b""), r"data/chunk-000/file-000\.parquet"),
    "data-truncated": (lambda w, d: _cut(d / DATA, 0.6), r"data/chunk-000/file-000\.parquet"),
    "data-missing": (lambda w, d: (d / DATA).unlink(), r"data/chunk-000/file-000\.parquet"),
    "data-folder": (lambda w, d: _to_folder(d / DATA), r"data/chunk-000/file-000\.parquet"),
    "video-empty": (lambda w, d: (d / VIDEO).write_bytes(b""), r"observation\.images\.front"),
    "video-truncated": (lambda w, d: _cut(d / VIDEO, 0.3), r"observation\.images\.front"),
    "video-missing": (lambda w, d: (d / VIDEO).unlink(), r"observation\.images\.front"),
    "video-folder": (lambda w, d: _to_folder(d / VIDEO), r"observation\.images\.front"),
    "video-garbage": (
        lambda w, d: (d / VIDEO).write_bytes(b"\x00\x00\x00\x18ftypgarbage" * 50),
        r"observation\.images",
    ),
    "openral-invalid": (lambda w, d: (d / "meta/openral.json").write_text("{"), r"openral\.json"),
    "openral-list": (lambda w, d: (d / "meta/openral.json").write_text("[]"), r"openral\.json"),
}

# command id -> (argv for the damaged dataset `d`, the outputs it would write)
READERS: dict[str, tuple[Callable[[Workspace, Path], list[str]], tuple[str, ...]]] = {
    "info": (lambda w, d: ["info", str(d)], ()),
    "stats": (lambda w, d: ["stats", str(d), "--format", "json"], ()),
    "convert": (lambda w, d: ["convert", str(d), str(w.root / "bags")], ("bags",)),
    "replay": (lambda w, d: ["replay", str(d), "--out", str(w.root / "res")], ("res",)),
    "delete": (lambda w, d: ["episodes", "delete", str(d), "--episodes", "0", "--out", str(w.root / "new")], ("new",)),
    "split": (
        lambda w, d: [
            "episodes",
            "split",
            str(d),
            "--episodes",
            "0",
            "--out",
            str(w.root / "a"),
            "--rest",
            str(w.root / "b"),
        ],
        ("a", "b"),
    ),
    "merge": (lambda w, d: ["episodes", "merge", str(w.ds("good")), str(d), "--out", str(w.root / "m")], ("m",)),
    "view": (lambda w, d: ["view", str(d), "--save", str(w.root / "v.rrd")], ("v.rrd",)),
    "reencode": (lambda w, d: ["videos", "reencode", str(d), "--codec", "h264", "--out", str(w.root / "v")], ("v",)),
    "recompute": (lambda w, d: ["stats", "recompute", str(d), "--out", str(w.root / "r")], ("r",)),
}

# which files each command reads (a damage elsewhere is not its business)
READS: dict[str, set[str]] = {
    "info": {"info", "episodes", "tasks"},
    "stats": {"info", "episodes", "tasks", "data", "openral"},
    "convert": {"info", "episodes", "tasks", "data", "video", "openral"},
    "replay": {"info", "episodes", "tasks", "data", "openral"},
    "delete": {"info", "episodes", "tasks", "data", "video", "openral"},
    "split": {"info", "episodes", "tasks", "data", "video", "openral"},
    "merge": {"info", "episodes", "tasks", "data", "video", "openral"},
    "view": {"info", "episodes", "tasks", "data", "video"},
    "reencode": {"info", "episodes", "tasks", "data", "video", "openral"},
    "recompute": {"info", "episodes", "tasks", "data", "video", "openral"},
}


# what a command does not read, and so rightly does not refuse
UNREAD = {
    "stats-tasks-missing",
    "stats-data-missing",
    "convert-openral-invalid",
    "convert-openral-list",
    "convert-info-directory",
    "view-tasks-garbage",
    "view-tasks-missing",
}


def _damage_case(reader: str, id: str, hurt: Callable[[Workspace, Path], object], names: str) -> None:
    argv, new = READERS[reader]

    def build(w: Workspace) -> list[str]:
        d = w.ds()
        hurt(w, d)
        return argv(w, d)

    case(id, build, names, new)


for _reader, _reads in READS.items():
    for _damage, (_hurt, _names) in DAMAGE.items():
        if _damage.split("-")[0] in _reads and f"{_reader}-{_damage}" not in UNREAD:
            _damage_case(_reader, f"{_reader}-{_damage}", _hurt, _names)


# ---------------------------------------------------------------------------------------------------------------
# Damaged replay results, read by stats and view --results


def _summary(r: Path, **changes: Any) -> None:
    import json

    summary = json.loads((r / "summary.json").read_text())
    summary.update(changes)
    (r / "summary.json").write_text(json.dumps(summary))


RESULTS_DAMAGE: dict[str, tuple[Callable[[Path], object], str]] = {
    "summary-not-utf8": (lambda r: (r / "summary.json").write_bytes(b'{"kind": "\xff"}'), r"summary\.json"),
    "summary-invalid-json": (lambda r: (r / "summary.json").write_text("{"), r"summary\.json"),
    "summary-list": (lambda r: (r / "summary.json").write_text("[]"), r"summary\.json"),
    "summary-format": (lambda r: _summary(r, format="other/9"), r"summary\.json: format"),
    "summary-kind": (lambda r: _summary(r, kind=["replay"]), r"summary\.json: kind"),
    "episodes-garbage": (lambda r: (r / "episodes.parquet").write_bytes(b"PAR1xxxxPAR1"), r"episodes\.parquet"),
    "episodes-empty": (lambda r: (r / "episodes.parquet").write_bytes(b""), r"episodes\.parquet"),
    "episodes-missing": (lambda r: (r / "episodes.parquet").unlink(), r"episodes\.parquet"),
    "steps-garbage": (lambda r: (r / "steps.parquet").write_bytes(b"\x00" * 99), r"steps\.parquet"),
    "steps-truncated": (lambda r: _cut(r / "steps.parquet", 0.5), r"steps\.parquet"),
    "steps-folder": (lambda r: _to_folder(r / "steps.parquet"), r"steps\.parquet"),
}
RESULTS_READERS: dict[str, tuple[Callable[[Workspace, Path], list[str]], tuple[str, ...]]] = {
    "stats": (lambda w, r: ["stats", str(r), "--format", "json"], ()),
    "view": (lambda w, r: ["view", str(w.ds()), "--results", str(r), "--save", str(w.root / "v.rrd")], ("v.rrd",)),
}


def _results_case(reader: str, damage: str) -> None:
    argv, new = RESULTS_READERS[reader]
    hurt, names = RESULTS_DAMAGE[damage]

    def build(w: Workspace) -> list[str]:
        r = w.res()
        hurt(r)
        return argv(w, r)

    case(f"{reader}-results-{damage}", build, names, new)


for _reader in RESULTS_READERS:
    for _damage in RESULTS_DAMAGE:
        _results_case(_reader, _damage)


# ---------------------------------------------------------------------------------------------------------------
# doctor --repair on something that is not a dataset folder: one line, and no lock (not even .openral/) is created


def _repair_file(w: Workspace) -> list[str]:
    w.write("notes.txt", "not a dataset")
    return ["doctor", str(w.root / "notes.txt"), "--repair"]


case("doctor-repair-file", _repair_file, r"notes\.txt")
case("doctor-repair-missing", lambda w: ["doctor", str(w.root / "gone"), "--repair"], r"gone", ("gone",))


# ---------------------------------------------------------------------------------------------------------------
# Silent wrong answers (#29): damage these commands used to read as a plausible answer, exiting 0 — episodes that
# are not there (`info`, the `datasets` view of `stats`), another episode's video frames or a task text of ""
# (`view`, `convert` to MCAP)


def _column(path: Path, name: str, value: Callable[[Any], Any]) -> None:
    import pyarrow as pa
    import pyarrow.parquet as pq

    t = pq.read_table(path)
    i = t.schema.get_field_index(name)
    t = t.set_column(i, name, pa.array([value(v) for v in t.column(name).to_pylist()], t.schema.field(i).type))
    pq.write_table(t, path)


FROM_TS = "videos/observation.images.front/from_timestamp"
TO_TS = "videos/observation.images.front/to_timestamp"
SILENT: dict[str, tuple[Callable[[Workspace, Path], object], str, tuple[str, ...]]] = {
    "info-total-episodes": (
        lambda w, d: _info(w, d, total_episodes=5),
        r"info\.json: total_episodes",
        ("info", "stats"),
    ),
    "info-total-frames": (lambda w, d: _info(w, d, total_frames=99), r"info\.json: total_frames", ("info",)),
    "info-total-tasks-zero": (
        lambda w, d: _info(w, d, total_tasks=0),
        r"info\.json: total_tasks: 0",
        ("info", "convert", "delete"),
    ),
    "episodes-length-negative": (
        lambda w, d: _column(d / EPISODES, "length", lambda v: -v),
        r"meta/episodes/: length",
        ("info",),  # stats reports it (health: frame_count)
    ),
    "episodes-video-from-negative": (
        lambda w, d: _column(d / EPISODES, FROM_TS, lambda v: -5.0),
        r"file-000\.mp4: episode 0: .*from_timestamp",
        ("view", "convert"),
    ),
    "episodes-video-to-beyond": (
        lambda w, d: _column(d / EPISODES, TO_TS, lambda v: v + 100),
        r"file-000\.mp4: episode 0: .*to_timestamp",
        ("view", "convert"),
    ),
    "data-task-index-out-of-range": (
        lambda w, d: _column(d / DATA, "task_index", lambda v: 7),
        r"file-000\.parquet: task_index: 7",
        ("convert",),
    ),
    "data-timestamp-nan": (  # not silent but a traceback: rerun cannot put a frame at time NaN
        lambda w, d: _column(d / DATA, "timestamp", lambda v: float("nan")),
        r"file-000\.parquet: timestamp",
        ("view",),
    ),
    "info-state-shape": (  # not silent but a traceback: the writer failed casting 8 values to the declared 99
        lambda w, d: _info(
            w, d, features={**_features(d), "observation.state": {**_features(d)["observation.state"], "shape": [99]}}
        ),
        r"info\.json: features: observation\.state: shape \[99\]",
        ("delete",),
    ),
    "data-task-index-negative": (
        lambda w, d: _column(d / DATA, "task_index", lambda v: -1),
        r"file-000\.parquet: task_index: -1",
        ("convert",),
    ),
}


for _damage, (_hurt, _names, _readers) in SILENT.items():
    for _reader in _readers:
        _damage_case(_reader, f"{_reader}-silent-{_damage}", _hurt, _names)


# path templates beyond lerobot's forms (#49): refused before they are formatted
_TEMPLATES = {
    "data-path-width-300": {"data_path": "data/chunk-{chunk_index:03d}/file-{file_index:0300d}.parquet"},
    "video-path-width-1e9": {"video_path": "videos/{video_key}/chunk-{chunk_index:0999999999d}/f-{file_index}.mp4"},
}


def _template_damage(change: dict[str, str]) -> Callable[[Workspace, Path], object]:
    return lambda w, d: _info(w, d, **change)


for _reader in ("info", "stats"):
    for _name, _change in _TEMPLATES.items():
        _damage_case(_reader, f"{_reader}-info-{_name}", _template_damage(_change), r"info\.json: \w+_path: ")
