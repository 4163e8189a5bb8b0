"""What the pages show of one dataset, read from its metadata: the episodes table (paged, sorted, filtered by the
`--where` of `episodes filter` through the same code, `metrics.where`), one episode's cameras and task, and its
state/action/reward series. Every query runs on one locked-down DuckDB connection (no other file, no network)."""

from __future__ import annotations

import math
import shlex
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import duckdb

from openral_data.browse._depth import depth_png, depth_unit
from openral_data.browse._pictures import picture_keys, picture_png
from openral_data.browse._results import ResultSet
from openral_data.browse._rows import EpisodeRows
from openral_data.browse._spans import quality_spans
from openral_data.errors import DatasetError, NotFound, QueryError
from openral_data.formats.lerobot_v3 import layout
from openral_data.formats.lerobot_v3.masks import is_mask
from openral_data.metrics.intervals import wilson
from openral_data.metrics.sources import DatasetSource
from openral_data.metrics.views import files_sql, ident
from openral_data.metrics.where import WHERE_VIEW, where_connection, where_query

COLUMNS = ("episode_index", "task", "length", "duration_s", "success", "seed")
QUALITY = "quality_flags"  # the column of the flags `openral-data quality` raised, when its table is cached
MAX_LIMIT = 500  # rows of one page
QUERY_SECONDS = 10.0  # a table query (its --where) is interrupted after this long
REWARD = "next.reward"


@dataclass
class Catalog:
    """One dataset as the server sees it; `arg` is the path as given on the command line (for the commands)."""

    ds: DatasetSource
    arg: str
    results: list[ResultSet] = field(default_factory=list)
    con: duckdb.DuckDBPyConnection = field(init=False)
    lock: threading.Lock = field(default_factory=threading.Lock, init=False)
    rows: EpisodeRows = field(default_factory=EpisodeRows, init=False)
    quality: bool = field(default=False, init=False)  # a current quality table is cached: its flags are a column
    query_seconds: float = field(default=QUERY_SECONDS, init=False)

    def __post_init__(self) -> None:
        self.con = where_connection(self.ds)  # with the `quality` view: the cached table, never computed here
        for r in self.results:  # Arrow tables, not files: the connection stays locked down to the dataset's
            self.con.register(r.view, r.table)
        self.quality = bool(self.con.execute("SELECT count(*) FROM quality").fetchone()[0])  # type: ignore[index]

    def close(self) -> None:
        self.con.close()

    def summary(self) -> dict[str, Any]:
        return {
            "label": self.ds.label,
            "path": self.arg,
            "fps": self.ds.fps,
            "episodes": int(self.ds.info.get("total_episodes", 0)),
            "cameras": self.ds.cameras,
            "results": [{"label": r.results.label, "kind": r.results.kind} for r in self.results],
        }

    @property
    def columns(self) -> list[dict[str, str]]:
        """The table's columns: the dataset's (`COLUMNS`), then each attached results folder's."""
        shown = [{"key": c, "label": c} for c in COLUMNS]
        if self.quality:  # `openral-data quality D` has run and its table is current
            shown.append({"key": QUALITY, "label": "quality flags"})
        return shown + [c for r in self.results for c in r.columns]

    def _select(self) -> str:
        """The table's SELECT list: a results column is looked up by episode_index in its registered table."""
        parts = [ident(c) for c in COLUMNS]
        if self.quality:  # the raised flags' names, "" for a clean episode (`metrics.quality.FLAGS`)
            parts.append(
                f"(SELECT array_to_string(q.flags, ', ') FROM quality q WHERE q.episode_index = "
                f"{WHERE_VIEW}.episode_index) AS {QUALITY}"
            )
        for r in self.results:
            for c in r.columns:
                key = ident(c["key"])
                parts.append(
                    f"(SELECT r.{key} FROM {ident(r.view)} r WHERE r.episode_index = {WHERE_VIEW}.episode_index) "
                    f"AS {key}"
                )
        return ", ".join(parts)

    def table(self, where: str, sort: str, desc: bool, offset: int, limit: int) -> dict[str, Any]:
        """One page of the episodes for which `where` holds (all when empty), with the filter's counts and
        success rate (Wilson 95 % interval over the episodes whose success is known)."""
        keys = [c["key"] for c in self.columns]
        if sort not in keys:
            raise QueryError(f"sort: {sort!r} is not one of {', '.join(keys)}")
        predicate = where if where.strip() else "TRUE"
        order = f"ORDER BY {ident(sort)} {'DESC' if desc else 'ASC'} NULLS LAST, episode_index"
        page = f"{order} LIMIT {max(1, min(limit, MAX_LIMIT))} OFFSET {max(0, offset)}"
        with self.lock, _deadline(self.con, self.query_seconds):
            ((n, known, wins),) = where_query(self.con, "count(*), count(success), count_if(success)", predicate)
            rows = where_query(self.con, self._select(), predicate, page)
        wins = wins or 0  # count_if over no row is NULL: a filter that matches nothing is an empty table
        interval = wilson(int(wins), int(known))
        return {
            "total": int(n),
            "known": int(known),
            "successes": int(wins),
            "rate": wins / known if known else None,
            "interval": [interval.low, interval.high] if known else None,
            "columns": self.columns,
            "rows": [dict(zip(keys, (_json(v) for v in r), strict=True)) for r in rows],
        }

    def episode(self, index: int) -> dict[str, Any]:
        """Episode `index`: task, length, and per camera its video span (from/to timestamps in the shared mp4)."""
        row = self._meta_row(index)
        with self.lock:
            found = self.con.execute(
                f"SELECT tasks, success, seed FROM {WHERE_VIEW} WHERE episode_index = ?", [index]
            ).fetchall()
        tasks, success, seed = found[0] if found else (None, None, None)
        cameras = []
        for i, cam in enumerate(self.ds.cameras):
            start, end = row.get(f"videos/{cam}/from_timestamp"), row.get(f"videos/{cam}/to_timestamp")
            if start is not None and end is not None:
                shown = {"key": cam, "url": f"video/{index}/{i}", "from": float(start), "to": float(end)}
                cameras.append({**shown, "depth": depth_unit(self.ds.info, cam)})
        features = self.ds.info.get("features", {})
        for j, key in enumerate(picture_keys(self.ds.info)):
            kind = "mask" if is_mask(features[key]) else "image"
            cameras.append({"key": key, "picture": j, "kind": kind})  # served at /d/N/picture/E/j/K
        return {
            "dataset": self.ds.label,
            "episode_index": index,
            "length": int(row["length"]),
            "fps": self.ds.fps,
            "tasks": list(tasks or []),
            "success": success,
            "seed": seed,
            "cameras": cameras,
            "results": {k: _json(v) for r in self.results for k, v in r.facts(index).items()},
        }

    def series(self, index: int) -> dict[str, Any]:
        """The episode's state/action/environment-state vectors (one series per dimension, named) and reward."""
        path = self._data_path(index, self._meta_row(index))
        keys = [*self.ds.vector_features, *([REWARD] if REWARD in self.ds.data_columns else [])]
        table = self.rows.read(path, index, ["frame_index", "timestamp", *keys])
        rows = list(zip(*(table.column(c).to_pylist() for c in table.column_names), strict=True))
        series = []
        for k, key in enumerate(keys, start=2):
            values = [r[k] for r in rows]
            if key == REWARD:
                series.append({"feature": key, "name": key, "values": [_json(v) for v in values]})
                continue
            names = self.ds.dim_names(key)
            vectors = [v if isinstance(v, list) or v is None else [v] for v in values]  # shape [1]: a scalar cell
            for d, name in enumerate(names):
                series.append({"feature": key, "name": name, "values": [_json(v[d]) if v else None for v in vectors]})
        for r in self.results:
            series.extend(r.series(index, [row[0] for row in rows]))
        return {"timestamps": [_json(r[1]) for r in rows], "series": series}

    def video(self, index: int, camera: int) -> str:
        """The mp4 holding camera number `camera` of episode `index`: its standard place inside the dataset
        (`layout.template_path`: refused, as not found, unless it stays inside after symlinks)."""
        if not 0 <= camera < len(self.ds.cameras):
            raise NotFound(f"no camera {camera}")
        key = self.ds.cameras[camera]
        row = self._meta_row(index)
        chunk, file = row.get(f"videos/{key}/chunk_index"), row.get(f"videos/{key}/file_index")
        if chunk is None or file is None:
            raise NotFound(f"episode {index}: no video for {key}")
        try:
            path = layout.template_path(self.ds.root, self.ds.info, "video_path", layout.FilePos(chunk, file), key)
        except DatasetError as exc:
            raise NotFound(str(exc)) from None
        return str(path)

    def depth(self, index: int, camera: int, frame: int) -> bytes:
        """Frame `frame` of depth camera number `camera` in episode `index`, as a grey PNG (`_depth`)."""
        if not 0 <= camera < len(self.ds.cameras) or depth_unit(self.ds.info, self.ds.cameras[camera]) is None:
            raise NotFound(f"no depth camera {camera}")
        self.video(index, camera)  # the mp4 is where the metadata says, inside the dataset
        try:
            return depth_png(self.ds.root, self.ds.info, self._meta_row(index), self.ds.cameras[camera], frame)
        except DatasetError as exc:
            raise NotFound(str(exc)) from None

    def picture(self, index: int, number: int, frame: int) -> bytes:
        """Frame `frame` of `dtype: image` feature number `number` in episode `index`, as a PNG (`_pictures`)."""
        keys = picture_keys(self.ds.info)
        if not 0 <= number < len(keys):
            raise NotFound(f"no picture feature {number}")
        row = self._meta_row(index)
        if not 0 <= frame < int(row["length"]):
            raise NotFound(f"no frame {frame}")
        key = keys[number]
        table = self.rows.read(self._data_path(index, row), index, [key])
        if frame >= table.num_rows:
            raise NotFound(f"episode {index}: no row for frame {frame}")
        source = f"{self.ds.root}: {key}: episode {index} frame {frame}"
        try:
            return picture_png(self.ds.info["features"][key], table.column(key)[frame].as_py(), source)
        except DatasetError as exc:
            raise NotFound(str(exc)) from None

    def commands(self, episodes: list[int], where: str) -> dict[str, Any]:
        """The commands that do what the selection says (the server runs none of them): the ticked `episodes`
        the filter `where` keeps (`picked`; those it hides are `hidden`, and left out of the commands)."""
        ticked = sorted(set(episodes))
        picked = ticked
        if ticked and where.strip():
            listed = ", ".join(str(e) for e in ticked)
            with self.lock, _deadline(self.con, self.query_seconds):
                kept = where_query(self.con, "episode_index", where, f"AND episode_index IN ({listed})")
            picked = sorted(int(r[0]) for r in kept)
        ds, shown = shlex.quote(self.arg), ",".join(str(e) for e in picked)
        out = {}
        if picked:
            out["delete"] = f"openral-data episodes delete {ds} --episodes {shown} --out {ds}-deleted"
            out["keep"] = f"openral-data episodes split {ds} --episodes {shown} --out {ds}-selected"
        if where.strip():
            out["filter"] = f"openral-data episodes filter {ds} --where {shlex.quote(where)} --out {ds}-filtered"
        return {"commands": out, "picked": picked, "hidden": sorted(set(ticked) - set(picked))}

    def neighbours(self, index: int, where: str) -> dict[str, int | None]:
        """The episodes before and after `index` in episode order, among those `where` keeps (all when empty)."""
        select = (
            f"max(episode_index) FILTER (WHERE episode_index < {int(index)}), "
            f"min(episode_index) FILTER (WHERE episode_index > {int(index)})"
        )
        with self.lock, _deadline(self.con, self.query_seconds):
            if where.strip():
                ((before, after),) = where_query(self.con, select, where)
            else:  # the episode_index column of the episodes metadata only: no join, no other column read
                sql = f"SELECT {select} FROM read_parquet({files_sql(self.ds.episode_files)})"
                before, after = self.con.execute(sql).fetchall()[0]
        return {"previous": before, "next": after}

    def findings(self, index: int) -> dict[str, Any]:
        """The flags `openral-data quality` raised on episode `index` and their frame spans (`_spans`); nothing
        when its table is not cached (`computed` false: the server never computes it)."""
        if not self.quality:
            return {"computed": False, "flags": [], "spans": []}
        with self.lock:
            flags = self.con.execute("SELECT flags FROM quality WHERE episode_index = ?", [index]).fetchall()
            spans = quality_spans(self.con, index)
        return {"computed": True, "flags": list(flags[0][0] or []) if flags else [], "spans": spans}

    def serve_command(self, index: int) -> str:
        """The command that keeps episode `index` in rerun's web viewer (its URL is what `browse --rerun-url`
        takes); the server does not run it."""
        return f"openral-data view {shlex.quote(self.arg)} --episode {index} --serve"

    def _data_path(self, index: int, row: dict[str, Any]) -> Path:
        """The data file holding episode `index` (its meta/episodes `row`), inside the dataset after symlinks."""
        chunk, file = row.get("data/chunk_index"), row.get("data/file_index")
        if chunk is None or file is None:
            raise NotFound(f"episode {index}: meta/episodes names no data file")
        return layout.template_path(self.ds.root, self.ds.info, "data_path", layout.FilePos(chunk, file))

    def _meta_row(self, index: int) -> dict[str, Any]:
        """Episode `index`'s meta/episodes row (only its location and span columns, not its stats)."""
        wanted = ["length", "data/chunk_index", "data/file_index"] + [
            f"videos/{cam}/{c}"
            for cam in self.ds.cameras
            for c in ("chunk_index", "file_index", "from_timestamp", "to_timestamp")
        ]
        have = [c for c in wanted if c in self.ds.episode_columns]
        sql = f"SELECT {', '.join(ident(c) for c in have)} FROM read_parquet({files_sql(self.ds.episode_files)}) "
        with self.lock:
            cur = self.con.execute(sql + "WHERE episode_index = ?", [index])
            rows = cur.fetchall()
        if not rows:
            raise NotFound(f"no episode {index}")
        return dict(zip(have, rows[0], strict=True))


@contextmanager
def _deadline(con: duckdb.DuckDBPyConnection, seconds: float) -> Iterator[None]:
    """Interrupt `con`'s query after `seconds`; the `QueryError` it then raises says so."""
    fired = threading.Event()

    def stop() -> None:
        fired.set()
        con.interrupt()

    timer = threading.Timer(seconds, stop)
    timer.start()
    try:
        yield
    except QueryError:
        if fired.is_set():
            raise QueryError(f"--where: stopped after {seconds:g} s (browse bounds each query)") from None
        raise
    finally:
        timer.cancel()


def _json(value: Any) -> Any:
    """A value JSON can carry: NaN/inf as null."""
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value
