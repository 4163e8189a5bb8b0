"""`stats --plot`: the figure built before saving — constant action dimensions at their value on a narrow axis,
histograms split into one series per `--by` group with counts that add up to each group's frames."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from matplotlib.figure import Figure
from matplotlib.patches import Rectangle, StepPatch

from openral_data.metrics.plot import Histogram, action_histograms, group_keys, group_label, plot_figure
from openral_data.metrics.report import Report, build_report, parse_by
from openral_data.metrics.sources import resolve
from openral_data.metrics.views import connect
from tests.support.metrics import copy_dataset, data_file, record_datasets, rewrite_parquet

JOINTS = ["joint1", "joint2", "joint3", "joint4", "joint5", "joint6", "gripper"]  # the mock robot's action names


@pytest.fixture(scope="module")
def pair(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[Path, Path]]:
    """A: random-mock actions (spread over [-1, 1]); B: zero-mock (every action dimension constant 0)."""
    yield record_datasets(tmp_path_factory.mktemp("plot"))


def _plot(paths: list[Path], by: str | None = None) -> tuple[Report, list[Histogram], Figure]:
    datasets, results = resolve([str(p) for p in paths])
    con = connect(datasets, results)
    try:
        report = build_report(con, datasets, results, parse_by(by), check_health=False)
        hists = action_histograms(con, datasets, group_keys(report))
        return report, hists, plot_figure(report, hists)
    finally:
        con.close()


def _group_frames(report: Report) -> dict[str, int]:
    keys = group_keys(report)
    return {group_label([r[k] for k in keys]): int(r["frames"]) for r in report.table("groups").records()}


def _legend(ax: Any) -> list[str]:
    legend = ax.get_legend()
    return [] if legend is None else [t.get_text() for t in legend.get_texts()]


def test_constant_dimensions_are_drawn_at_their_value_on_a_narrow_axis(pair: tuple[Path, Path], tmp_path: Path) -> None:
    b = copy_dataset(pair[1], tmp_path / "b_const")
    table = pq.read_table(data_file(b))
    actions = np.array(table.column("action").to_pylist(), dtype=np.float32)
    assert not actions.any()  # zero-mock
    actions[:, 0] = 2.5  # joint1 constant 2.5, the others constant 0
    column = pa.FixedSizeListArray.from_arrays(pa.array(actions.ravel()), actions.shape[1])
    rewrite_parquet(data_file(b), table.set_column(table.schema.get_field_index("action"), "action", column))

    report, hists, fig = _plot([b])
    frames = _group_frames(report)[b.name]
    assert [h.name for h in hists] == JOINTS
    assert all(h.constant for h in hists)
    assert [h.low for h in hists] == [2.5] + [0.0] * 6
    assert all(h.series == {b.name: [frames] + [0] * 39} for h in hists)
    axes = fig.axes[1:]
    assert len(axes) == len(JOINTS)
    for ax, value in zip(axes, [2.5] + [0.0] * 6, strict=True):
        lo, hi = ax.get_xlim()
        assert lo < value < hi and hi - lo <= 0.1 * max(abs(value), 1.0), (ax.get_title(), lo, hi)
        assert "constant" in ax.get_title() and f"{value:g}" in ax.get_title()
        bars = [p for p in ax.patches if isinstance(p, Rectangle)]
        assert len(ax.patches) == len(bars) == 1 and bars[0].get_height() == frames
        assert lo <= bars[0].get_x() and bars[0].get_x() + bars[0].get_width() <= hi
    assert [t.get_text() for t in axes[0].get_xticklabels()] == ["2.5"]


@pytest.mark.parametrize("by", [None, "rskill", "dataset,rskill"])
def test_histograms_have_one_series_per_group(pair: tuple[Path, Path], by: str | None) -> None:
    report, hists, fig = _plot(list(pair), by)
    frames = _group_frames(report)
    assert len(frames) == 2
    assert [h.name for h in hists] == JOINTS
    for h, ax in zip(hists, fig.axes[1:], strict=True):
        assert not h.constant and h.low <= 0 <= h.high  # A's actions spread, B's zeros inside them
        # every finite action value of each group is counted once, on the shared bins
        assert {label: sum(c) for label, c in h.series.items()} == frames
        steps = [p for p in ax.patches if isinstance(p, StepPatch)]
        assert len(steps) == 2 and _legend(ax) == sorted(frames)
        assert ax.get_xlim() == (h.low, h.high)
        for step, label in zip(steps, sorted(frames), strict=True):
            assert list(step.get_data()[0]) == h.series[label]  # (values, edges, baseline)


def test_many_groups_split_one_dataset(pair: tuple[Path, Path]) -> None:
    report, hists, fig = _plot([pair[0]], "seed")
    frames = _group_frames(report)
    assert len(frames) == 8  # one group per episode seed
    for h, ax in zip(hists, fig.axes[1:], strict=True):
        assert {label: sum(c) for label, c in h.series.items()} == frames
        assert len(_legend(ax)) == 8
