"""A DuckDB connection whose views read datasets and results in place (read_parquet, nothing loaded up front).

Views (documented in docs/stats.md):

* `frames`   — every data-parquet row of every dataset, plus a `dataset` column.
* `episodes` — one row per episode: dataset, episode_index, length, duration_s, tasks, task, success, seed,
  scene, rskill, robot, dataset_from_index, dataset_to_index. `success` follows the one rule of
  `formats.lerobot_v3.success`: our `openral.success` when it holds a value, else whether any frame of the
  episode has `next.success`, else NULL (unknown, never guessed).
* `randomization` — one row per value a randomized scene drew for an episode (`scene.params.randomize`, stored
  in `openral.initial_state`): dataset, episode_index, key (`light.diffuse[0]`, `textures.table`,
  `distractors.count`, ...), value (DOUBLE, numbers) and text (VARCHAR, names).
* `interventions` / `intervention_episodes` — a person's takeovers from the policy and each episode's rate
  (metrics/intervention_sql.py); empty for datasets without `openral.intervention`.
* `tasks`    — dataset, task_index, task.
* `datasets` — one row per dataset: dataset, path, fps, robot_type, episodes, frames, scene, rskill, robot.
* `results`  / `result_steps` — replay/eval results (see `formats/results.py`), with `results`, `kind`
  and `dataset` columns.
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

import duckdb
import pyarrow as pa

from openral_data.errors import QueryError
from openral_data.formats.lerobot_v3 import layout
from openral_data.formats.lerobot_v3.reader import read_tasks_table
from openral_data.formats.lerobot_v3.success import EPISODE_SUCCESS, episode_successes
from openral_data.formats.results import Results
from openral_data.metrics import intervention_sql
from openral_data.metrics.sources import DatasetSource

DEFAULT_MEMORY_LIMIT = "1GB"


def lit(value: object) -> str:
    """An SQL literal for a str/int/float/None."""
    if value is None:
        return "NULL"
    if isinstance(value, bool):
        return "TRUE" if value else "FALSE"
    if isinstance(value, int | float):
        return repr(value)
    return "'" + str(value).replace("'", "''") + "'"


def ident(name: str) -> str:
    return '"' + name.replace('"', '""') + '"'


_GLOB = re.compile(r"([*?\[])")


def glob_escape(path: str) -> str:
    """`path` as a DuckDB file pattern that matches only itself. DuckDB globs every file name it is given, so a
    dataset folder named `ds[1]` would otherwise read its sibling `ds1` (`[1]` is a character class)."""
    return _GLOB.sub(r"[\1]", path)


def path_sql(path: Path) -> str:
    """A file for `read_parquet`: an SQL literal, its glob characters escaped."""
    return lit(glob_escape(str(path)))


def files_sql(files: Sequence[Path]) -> str:
    return "[" + ", ".join(path_sql(f) for f in files) + "]"


def view_files(datasets: Sequence[DatasetSource], results: Sequence[Results] = ()) -> list[Path]:
    """Every file the views read."""
    out = [f for ds in datasets for f in (*ds.data_files, *ds.episode_files, ds.root / layout.TASKS_PATH)]
    return out + [f for r in results for f in (r.episodes_path, r.steps_path)]


def episodes_from(ds: DatasetSource) -> str:
    """`ds`'s episodes table in SQL: read_parquet of meta/episodes/, or a v2.x dataset's table as `connect`
    registers it."""
    if ds.episodes_table is not None:
        return ident(f"episodes:{ds.label}")
    return f"read_parquet({files_sql(ds.episode_files)})"


def lock_down(con: duckdb.DuckDBPyConnection, files: Iterable[Path]) -> None:
    """From here on `con` reads `files` and nothing else, for good: user-given SQL (`stats --sql`, `--where`) can
    no longer read or write any other file (COPY, ATTACH, EXPORT, read_csv, glob), reach the network, install
    or load an extension, or change a setting back (docs/threat-model.md). Views created before keep working."""
    allowed = sorted({p for f in files for p in (str(f), glob_escape(str(f)))})
    con.execute(f"SET allowed_paths = [{', '.join(lit(p) for p in allowed)}]")
    con.execute("SET enable_external_access = false")
    con.execute("SET lock_configuration = true")


def check_select(con: duckdb.DuckDBPyConnection, sql: str, option: str) -> None:
    """User-given SQL may only query: every statement a SELECT. An allowed file could otherwise be overwritten
    (`COPY ... TO` one of the views' own files) and `EXPLAIN ANALYZE` runs what it explains."""
    try:
        kinds = [s.type for s in con.extract_statements(sql)]
    except duckdb.Error as exc:
        raise QueryError(f"{option}: {str(exc).splitlines()[0]}") from None
    bad = sorted({k.name for k in kinds if k != duckdb.StatementType.SELECT})
    if bad or not kinds:
        raise QueryError(f"{option}: only SELECT queries may run here, not {', '.join(bad) or 'nothing'}")


def connect(
    datasets: Sequence[DatasetSource],
    results: Sequence[Results] = (),
    memory_limit: str = DEFAULT_MEMORY_LIMIT,
) -> duckdb.DuckDBPyConnection:
    con = duckdb.connect(":memory:")
    try:
        con.execute(f"SET memory_limit = {lit(memory_limit)}")
    except duckdb.Error as exc:
        con.close()
        raise QueryError(f"--memory-limit {memory_limit!r}: {str(exc).splitlines()[0]}") from None
    con.execute("SET preserve_insertion_order = false")
    # LeRobot v3 data files hold one small row group per episode; DuckDB's prefetch of parquet ranges then
    # reads far more bytes than the columns asked for (measured ~1.6x slower on the benchmark dataset)
    con.execute("SET disable_parquet_prefetching = true")
    # each data file is scanned by several queries (summaries, health, per-episode success); with one row
    # group per episode its footer is large, so parse it once per run (DuckDB checks the file's mtime)
    con.execute("SET parquet_metadata_cache = true")
    _register_datasets(con, datasets)
    _register_results(con, results, datasets)
    return con


def _union(parts: list[str], empty: str) -> str:
    return "\nUNION ALL BY NAME\n".join(parts) if parts else empty


def _register_datasets(con: duckdb.DuckDBPyConnection, datasets: Sequence[DatasetSource]) -> None:
    frames = [
        f"SELECT {lit(ds.label)} AS dataset, * FROM read_parquet({files_sql(ds.data_files)})"
        for ds in datasets
        if ds.data_files
    ]
    con.execute(
        "CREATE VIEW frames AS "
        + _union(
            frames, "SELECT NULL::VARCHAR AS dataset, NULL::BIGINT AS episode_index, NULL::BIGINT AS index LIMIT 0"
        )
    )
    parts = []
    for i, ds in enumerate(datasets):
        con.register(f"success_{i}", _success_table(ds))
        if ds.episodes_table is not None and ds.tasks_table is not None:  # v2.x: read from JSON lines
            con.register(f"episodes:{ds.label}", ds.episodes_table)
            con.register(f"tasks:{ds.label}", ds.tasks_table)
        parts.append(_episodes_sql(ds, f"success_{i}"))
    con.execute("CREATE VIEW episodes AS " + _union(parts, _EMPTY_EPISODES))
    drawn = [_randomization_sql(ds) for ds in datasets if "openral.initial_state" in ds.episode_columns]
    con.execute("CREATE VIEW randomization AS " + _union(drawn, _EMPTY_RANDOMIZATION))
    flagged = [ds for ds in datasets if intervention_sql.records_interventions(ds)]
    for statement in intervention_sql.view_statements(
        [(lit(ds.label), f"read_parquet({files_sql(ds.data_files)})") for ds in flagged]
    ):
        con.execute(statement)
    _register_tasks(con, datasets)
    rows = [
        "("
        + ", ".join(
            lit(v)
            for v in (
                ds.label,
                str(ds.root),
                ds.fps,
                ds.info.get("robot_type"),
                int(ds.info.get("total_episodes", 0)),
                int(ds.info.get("total_frames", 0)),
                ds.scene,
                ds.rskill,
                ds.robot,
            )
        )
        + ")"
        for ds in datasets
    ]
    cols = "dataset, path, fps, robot_type, episodes, frames, scene, rskill, robot"
    types = "VARCHAR, VARCHAR, BIGINT, VARCHAR, BIGINT, BIGINT, VARCHAR, VARCHAR, VARCHAR"
    typed = ", ".join(
        f"{c.strip()}::{t.strip()} AS {c.strip()}" for c, t in zip(cols.split(","), types.split(","), strict=True)
    )
    body = (
        f"SELECT {typed} FROM (VALUES {', '.join(rows)}) v({cols})"
        if rows
        else f"SELECT {typed} FROM (SELECT {', '.join('NULL' for _ in cols.split(','))}) v({cols}) LIMIT 0"
    )
    con.execute("CREATE VIEW datasets AS " + body)


def _register_tasks(con: duckdb.DuckDBPyConnection, datasets: Sequence[DatasetSource]) -> None:
    """The `tasks` view: meta/tasks.parquet in any layout lerobot reads (older lerobot's unnamed pandas index too:
    `reader.read_tasks_table`), or a v2.x dataset's table (from meta/tasks.jsonl)."""
    tasks = []
    for i, ds in enumerate(datasets):
        table = ds.tasks_table
        if table is None and (ds.root / layout.TASKS_PATH).is_file():
            table = read_tasks_table(ds.root)
        if table is not None:
            con.register(f"tasks_{i}", table)
            tasks.append(f"SELECT {lit(ds.label)} AS dataset, task_index, task FROM tasks_{i}")
    con.execute(
        "CREATE VIEW tasks AS "
        + _union(tasks, "SELECT NULL::VARCHAR AS dataset, NULL::BIGINT AS task_index, NULL::VARCHAR AS task LIMIT 0")
    )


_EMPTY_EPISODES = (
    "SELECT NULL::VARCHAR AS dataset, NULL::BIGINT AS episode_index, NULL::BIGINT AS length, "
    "NULL::DOUBLE AS duration_s, NULL::VARCHAR[] AS tasks, NULL::VARCHAR AS task, NULL::BOOLEAN AS success, "
    "NULL::BIGINT AS seed, NULL::VARCHAR AS scene, NULL::VARCHAR AS rskill, NULL::VARCHAR AS robot, "
    "NULL::VARCHAR AS operator LIMIT 0"
)


_EMPTY_RANDOMIZATION = (
    "SELECT NULL::VARCHAR AS dataset, NULL::BIGINT AS episode_index, NULL::VARCHAR AS key, NULL::DOUBLE AS value, "
    "NULL::VARCHAR AS text LIMIT 0"
)


def _randomization_sql(ds: DatasetSource) -> str:
    """The leaves of each episode's `randomization` (initial state JSON) as rows."""
    return (
        f"SELECT {lit(ds.label)} AS dataset, e.episode_index, substr(t.fullkey, 3) AS key, "
        "TRY_CAST(t.value AS DOUBLE) AS value, CASE WHEN t.type = 'VARCHAR' THEN t.value ->> '$' END AS text "
        f"FROM {episodes_from(ds)} e, "
        """json_tree(json_extract(e."openral.initial_state", '$.randomization')) t """
        "WHERE t.type NOT IN ('OBJECT', 'ARRAY')"
    )


def _success_table(ds: DatasetSource) -> pa.Table:
    """episode_index -> success by the one rule (`formats.lerobot_v3.success`), NULL where unknown."""
    cols = ["episode_index"] + [c for c in (EPISODE_SUCCESS,) if c in ds.episode_columns]
    episodes = ds.read_episodes(cols)
    found = episode_successes(ds.root, episodes)
    return pa.table(
        {"episode_index": pa.array(list(found), pa.int64()), "success": pa.array(list(found.values()), pa.bool_())}
    )


def _episodes_sql(ds: DatasetSource, success_view: str) -> str:
    cols = ds.episode_columns
    join = f"LEFT JOIN {success_view} s USING (episode_index)"
    success = "s.success"
    seed = 'e."openral.seed"' if "openral.seed" in cols else "NULL::BIGINT"
    tasks = "e.tasks" if "tasks" in cols else "NULL::VARCHAR[]"
    span = (
        "e.dataset_from_index, e.dataset_to_index"
        if {"dataset_from_index", "dataset_to_index"} <= cols
        else "NULL::BIGINT AS dataset_from_index, NULL::BIGINT AS dataset_to_index"
    )
    # who drove (record --hal: `operator` in the episode's JSON report): policy:<rskill>, teleop:<device>
    info = '"openral.episode_info"'
    operator = f"json_extract_string(e.{info}, '$.operator')" if "openral.episode_info" in cols else "NULL"
    return (
        f"SELECT {lit(ds.label)} AS dataset, episode_index, e.length, e.length / {ds.fps}::DOUBLE AS duration_s, "
        f"{tasks} AS tasks, {tasks}[1] AS task, {success} AS success, {seed} AS seed, "
        f"{lit(ds.scene)}::VARCHAR AS scene, {lit(ds.rskill)}::VARCHAR AS rskill, {lit(ds.robot)}::VARCHAR AS robot, "
        f"{span}, {operator}::VARCHAR AS operator FROM {episodes_from(ds)} e {join}"
    )


def _register_results(
    con: duckdb.DuckDBPyConnection, results: Sequence[Results], datasets: Sequence[DatasetSource]
) -> None:
    by_root = {ds.root.resolve(): ds.label for ds in datasets}
    eps, steps = [], []
    for r in results:
        ref = r.dataset
        dataset = by_root.get(Path(ref).resolve(), Path(ref).name) if ref is not None else None
        head = f"SELECT {lit(r.label)} AS results, {lit(r.kind)} AS kind, {lit(dataset)}::VARCHAR AS dataset"
        eps.append(f"{head}, * FROM read_parquet({path_sql(r.episodes_path)})")
        steps.append(f"{head}, * FROM read_parquet({path_sql(r.steps_path)})")
    empty = (
        "SELECT NULL::VARCHAR AS results, NULL::VARCHAR AS kind, NULL::VARCHAR AS dataset, "
        "NULL::BIGINT AS episode_index LIMIT 0"
    )
    con.execute("CREATE VIEW results AS " + _union(eps, empty))
    con.execute("CREATE VIEW result_steps AS " + _union(steps, empty))


def query(con: duckdb.DuckDBPyConnection, sql: str) -> tuple[list[str], list[tuple[Any, ...]]]:
    """Run `sql` to completion: (column names, rows)."""
    cur = con.execute(sql)
    rows = cur.fetchall()
    columns = [d[0] for d in cur.description] if cur.description else []
    return columns, rows
