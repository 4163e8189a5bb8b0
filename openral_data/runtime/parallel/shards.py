"""The workers' shares of a parallel run (`record --workers`, `convert --workers`) merged into one dataset: the
merge `episodes merge` uses (`edit.ops.write_selection`: rows re-indexed, videos remuxed, no re-encode), with
camera statistics from the shares' summed histograms, so exact."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from openral_data.edit.ops import Rewrite, Transform, summed_histograms, write_selection
from openral_data.edit.source import SourceDataset
from openral_data.errors import ExecutorError

Episode = tuple[SourceDataset, int]


def merge_shards(
    shares: Sequence[SourceDataset],
    dst: Path,
    op: str,
    *,
    where: Path,
    order: Callable[[Episode], Any] | None = None,
    transform: Transform | None = None,
    before_publish: Callable[[Path], None] | None = None,
    before_rename: Callable[[], None] | None = None,
    out_checked: bool = False,
) -> None:
    """Every episode of `shares` (in their order, or sorted by `order`), rewritten by `transform`, as one dataset
    at `dst`; a share without camera histograms is refused, naming `where`. `before_publish`, `before_rename` and
    `out_checked` as `write_selection` takes them."""
    hist = summed_histograms(shares)
    if hist is None:
        raise ExecutorError(f"{where}: a worker left no camera histograms (.openral/image_hist.json)")
    selection = [(s, e) for s in shares for e in range(s.total)]
    if order is not None:
        selection.sort(key=order)
    write_selection(
        selection,
        dst,
        op,
        before_publish=before_publish,
        before_rename=before_rename,
        out_checked=out_checked,
        rewrite=Rewrite(transform=transform, image_hist=hist),
    )
