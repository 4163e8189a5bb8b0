"""`features add --name KEY --sql EXPR`: a new per-frame column computed by DuckDB from the frame's columns.

EXPR is one DuckDB expression over a data file's columns as stored (`action`, `"observation.state"`,
`timestamp`, `frame_index`, `episode_index`, ...; lists are 1-based: `action[7]`), evaluated once per data file
(`SELECT EXPR FROM read_parquet(FILE) WINDOW ep AS (PARTITION BY episode_index ORDER BY frame_index)`, one file in
memory at a time, as editing reads them), so window functions work over an episode as `OVER ep` (`action[1] -
lag(action[1], 1, action[1]) OVER ep`). Element-wise list arithmetic is not DuckDB's: `vsub(a, b)`, `vadd(a, b)`
and `vscale(a, s)` are defined (`vsub(action, "observation.state")`). The connection reads the dataset's data
files and nothing else (`metrics.views.lock_down`).

The result must be numbers: a number, a boolean, or a list of them of the same length in every frame, never
NULL. Its `dtype` is `--dtype` (float32, int64 or bool; the value cast) or inferred (a boolean bool, an integer
int64, anything else float32), its shape `[1]` for a scalar or `[length]` for a list (`--shape N` must agree),
`names` from `--names` or null. The column is written as a carried numeric feature: its statistics are computed
from its rows per episode and for the dataset, as every numeric feature's; every other column and file is
copied as the other edits copy them. Anything else is one line, exit 2, nothing written.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import duckdb
import numpy as np
import numpy.typing as npt
import pyarrow as pa
import pyarrow.compute as pc

from openral_data.edit.ops import EditResult, Rewrite, check_edit_output, summed_histograms, write_edit
from openral_data.edit.renames import RESERVED
from openral_data.edit.source import EpisodeData, SourceDataset
from openral_data.errors import QueryError, UsageError
from openral_data.formats.lerobot_v3 import layout
from openral_data.formats.lerobot_v3.features import data_schema
from openral_data.metrics.views import lock_down, path_sql

DTYPES = ("float32", "int64", "bool")
MACROS = (
    "CREATE MACRO vsub(a, b) AS list_transform(list_zip(a, b), lambda p: p[1] - p[2])",
    "CREATE MACRO vadd(a, b) AS list_transform(list_zip(a, b), lambda p: p[1] + p[2])",
    "CREATE MACRO vscale(a, s) AS list_transform(a, lambda x: x * s)",
)


def add(
    dataset: Path,
    name: str,
    sql: str,
    out: Path | None,
    in_place: bool = False,
    dtype: str | None = None,
    shape: int | None = None,
    names: Sequence[str] = (),
) -> EditResult:
    """Write `dataset` with a new feature `name`, each frame's value `sql` evaluated over its columns."""
    check_edit_output(out, in_place)
    src = SourceDataset(dataset)
    _check_name(src, name)
    if dtype is not None and dtype not in DTYPES:
        raise UsageError(f"--dtype: {dtype!r} is not one of {', '.join(DTYPES)}")
    column = DerivedColumn(src, sql)
    try:
        feature = column.feature(dtype, shape, names)
        features = {**src.features, name: feature}  # lerobot reads any order; the new column goes last
        kind = data_schema({name: feature}).field(name).type

        def with_column(ep: EpisodeData) -> EpisodeData:
            values = column.values(ep.index, ep.length, feature)
            return dataclasses.replace(ep, columns={**ep.columns, name: values.cast(kind)})

        rewrite = Rewrite(
            transform=with_column,
            features=features,
            image_hist=summed_histograms([src]),
            details={"added": {name: sql}},
        )
        return write_edit([(src, e) for e in range(src.total)], dataset, out, in_place, "features add", rewrite)
    finally:
        column.close()


def _check_name(src: SourceDataset, name: str) -> None:
    if name in RESERVED:
        raise UsageError(f"--name: {name} is a name openral-data and lerobot reserve")
    if name in src.features:
        raise UsageError(f"--name: {src.root} already has a feature {name!r}")
    if not name or name in (".", "..") or any(c in name for c in "/\\\x00") or not name.isprintable():
        raise UsageError(f"--name: {name!r} cannot be a feature key")


class DerivedColumn:
    """`sql` evaluated one data file at a time (the last file's values kept until an episode of another one)."""

    def __init__(self, src: SourceDataset, sql: str) -> None:
        self.src, self.sql = src, sql
        rows = src.episodes.select(["data/chunk_index", "data/file_index"]).to_pylist()[: src.total]
        self.files = [
            layout.data_path(src.root, layout.FilePos(int(r["data/chunk_index"]), int(r["data/file_index"])))
            for r in rows
        ]
        self._cache: tuple[Path, dict[int, npt.NDArray[Any]]] | None = None
        if not sql.strip():
            raise UsageError("--sql: empty expression")
        self.con = duckdb.connect(":memory:")
        try:
            for macro in MACROS:
                self.con.execute(macro)
            lock_down(self.con, sorted(set(self.files)))
            self._check_one(sql)
        except BaseException:
            self.con.close()
            raise

    def _check_one(self, sql: str) -> None:
        """Refuse `sql` unless it is one expression (not `1) FROM t; SELECT (1`)."""
        try:
            one = len(self.con.extract_statements(f"SELECT ({sql}) FROM t WINDOW ep AS (PARTITION BY e ORDER BY f)"))
        except duckdb.Error as exc:
            raise QueryError(f"--sql: {str(exc).splitlines()[0]}") from None
        if one != 1:
            raise QueryError(f"--sql: {sql!r} is not one expression")

    def close(self) -> None:
        self.con.close()

    def feature(self, dtype: str | None, shape: int | None, names: Sequence[str]) -> dict[str, Any]:
        """The info.json feature of the column, its width and dtype from the first episode's values."""
        first = self._file(self.files[0])
        sample = next(iter(first.values()))
        inferred = (
            "bool" if sample.dtype == np.bool_ else "int64" if np.issubdtype(sample.dtype, np.integer) else "float32"
        )
        width = sample.shape[1]
        if shape is not None and shape != width:
            raise UsageError(f"--shape: {shape} but --sql gives {width} value(s) a frame")
        if names and len(names) != width:
            raise UsageError(f"--names: {len(names)} names for {width} value(s) a frame")
        return {"dtype": dtype or inferred, "shape": [width], "names": list(names) or None}

    def values(self, episode: int, length: int, feature: dict[str, Any]) -> pa.Array:
        """The episode's values as the feature's Arrow type (a scalar column or a fixed-size list)."""
        matrix = self._file(self.files[episode]).get(episode)
        where = f"--sql: {self.src.root}: episode {episode}"
        if matrix is None or len(matrix) != length:
            raise QueryError(f"{where}: {0 if matrix is None else len(matrix)} values for {length} frames")
        if matrix.shape[1] != feature["shape"][0]:
            raise QueryError(f"{where}: {matrix.shape[1]} values a frame, other frames have {feature['shape'][0]}")
        base = {"float32": pa.float32(), "int64": pa.int64(), "bool": pa.bool_()}[feature["dtype"]]
        try:
            flat = pa.array(matrix.reshape(-1)).cast(base)
        except (pa.ArrowInvalid, pa.ArrowNotImplementedError) as exc:
            raise QueryError(f"{where}: the values are not {feature['dtype']}: {str(exc).splitlines()[0]}") from None
        return flat if feature["shape"] == [1] else pa.FixedSizeListArray.from_arrays(flat, matrix.shape[1])

    def _file(self, path: Path) -> dict[int, npt.NDArray[Any]]:
        if self._cache is None or self._cache[0] != path:
            self._cache = (path, self._evaluate(path))
        return self._cache[1]

    def _evaluate(self, path: Path) -> dict[int, npt.NDArray[Any]]:
        """Episode index -> its values, frames in order, one row a frame (frames, width)."""
        query = (
            f"SELECT * FROM (SELECT episode_index AS e, frame_index AS f, ({self.sql}) AS v "
            f"FROM read_parquet({path_sql(path)}) WINDOW ep AS (PARTITION BY episode_index ORDER BY frame_index)) "
            "ORDER BY e, f"
        )
        try:
            table = self.con.sql(query).to_arrow_table()
        except duckdb.Error as exc:
            raise QueryError(f"--sql: {str(exc).splitlines()[0]}") from None
        matrix = _matrix(table.column("v").combine_chunks(), f"--sql: {path}")
        episodes = table.column("e").to_numpy()
        out: dict[int, npt.NDArray[Any]] = {}
        for e in np.unique(episodes):
            out[int(e)] = matrix[episodes == e]
        return out


def _matrix(values: pa.Array, where: str) -> npt.NDArray[Any]:
    """A result column as (rows, width) numbers; one line for NULLs, ragged lists or anything not numeric."""
    kind = values.type
    if pa.types.is_list(kind) or pa.types.is_fixed_size_list(kind) or pa.types.is_large_list(kind):
        if values.null_count:
            raise QueryError(f"{where}: the expression is NULL in some frame")
        lengths = pc.list_value_length(values).to_numpy(zero_copy_only=False)
        if len(lengths) and (lengths.min() != lengths.max() or lengths.min() == 0):
            raise QueryError(
                f"{where}: the expression gives lists of {lengths.min()} to {lengths.max()} values (ragged)"
            )
        inner = values.flatten()
        return _numbers(inner, where).reshape(len(values), -1)
    return _numbers(values, where).reshape(-1, 1)


def _numbers(values: pa.Array, where: str) -> npt.NDArray[Any]:
    kind = values.type
    if not (
        pa.types.is_integer(kind)
        or pa.types.is_floating(kind)
        or pa.types.is_boolean(kind)
        or pa.types.is_decimal(kind)
    ):
        raise QueryError(f"{where}: the expression gives {kind} values, not numbers")
    if values.null_count:
        raise QueryError(f"{where}: the expression is NULL in some frame (coalesce it, e.g. lag(x, 1, x) OVER ep)")
    if pa.types.is_decimal(kind):
        values = values.cast(pa.float64())
    return np.asarray(values.to_numpy(zero_copy_only=False))
