"""Two datasets side by side (`/compare?a=I&b=J`): each one's episodes table on the same columns (the dataset
columns every table has) under the same `--where`, and the difference of their success rates (B - A) with its
95 % Newcombe interval and Fisher's exact p-value, as `stats` compares groups (`metrics.intervals`)."""

from __future__ import annotations

from typing import Any

from openral_data.browse._catalog import COLUMNS, Catalog
from openral_data.errors import QueryError
from openral_data.metrics.intervals import fisher_exact, newcombe


def compare(a: Catalog, b: Catalog, where: str, sort: str, desc: bool, limit: int) -> dict[str, Any]:
    """Both tables' first `limit` rows by `sort` (one of `COLUMNS`) where `where` holds, and the difference."""
    if sort not in COLUMNS:
        raise QueryError(f"sort: {sort!r} is not one of {', '.join(COLUMNS)}")
    sides = {}
    for name, cat in (("a", a), ("b", b)):
        try:
            body = cat.table(where, sort, desc, 0, limit)
        except QueryError as exc:  # a column one dataset lacks: say which side refused it
            raise QueryError(f"{cat.ds.label}: {exc}") from None
        body["rows"] = [{c: r[c] for c in COLUMNS} for r in body["rows"]]
        body["columns"] = [c for c in body["columns"] if c["key"] in COLUMNS]
        sides[name] = {**cat.summary(), **body}
    k1, n1 = sides["a"]["successes"], sides["a"]["known"]
    k2, n2 = sides["b"]["successes"], sides["b"]["known"]
    difference: dict[str, Any] | None = None
    if n1 and n2:
        interval = newcombe(k2, n2, k1, n1)
        difference = {"rate": k2 / n2 - k1 / n1, "interval": [interval.low, interval.high]}
        difference["fisher_p"] = fisher_exact(k1, n1, k2, n2)
    return {**sides, "difference": difference}
