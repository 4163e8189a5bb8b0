"""`stats --plot`: a group has one colour in every panel (its success-rate bar and its series in each action
histogram), so a colour means the same dataset everywhere in the PNG."""

from __future__ import annotations

from pathlib import Path

import pytest
from matplotlib.colors import to_rgba
from matplotlib.patches import Rectangle, StepPatch

from openral_data.metrics.plot import action_histograms, group_colours, group_keys, plot_figure
from openral_data.metrics.report import build_report, parse_by
from openral_data.metrics.sources import resolve
from openral_data.metrics.views import connect
from tests.support.inproc import run_inproc
from tests.support.metrics import record_datasets


@pytest.fixture(scope="module")
def pair(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    return record_datasets(tmp_path_factory.mktemp("plot_colours"))


def test_each_group_keeps_its_colour_across_panels(pair: tuple[Path, Path], tmp_path: Path) -> None:
    run = run_inproc("stats", *map(str, pair), "--plot", str(tmp_path / "p.png"))
    assert run.returncode == 0, run.stderr
    assert (tmp_path / "p.png").stat().st_size > 0
    datasets, results = resolve([str(p) for p in pair])
    con = connect(datasets, results)
    try:
        report = build_report(con, datasets, results, parse_by(None), check_health=False)
        fig = plot_figure(report, action_histograms(con, datasets, group_keys(report)))
    finally:
        con.close()
    colours = {label: to_rgba(c)[:3] for label, c in group_colours(report).items()}
    assert len(set(colours.values())) == len(colours) == 2
    rates, *panels = fig.axes
    bars = [p for p in rates.patches if isinstance(p, Rectangle)]
    ticks = [t.get_text().split("\n")[0] for t in rates.get_xticklabels()]
    assert [to_rgba(b.get_facecolor())[:3] for b in bars] == [colours[t] for t in ticks]
    checked = 0
    for ax in panels:
        for patch in ax.patches:
            label = patch.get_label()
            if label in colours:
                seen = patch.get_edgecolor() if isinstance(patch, StepPatch) else patch.get_facecolor()
                assert to_rgba(seen)[:3] == colours[label], (ax.get_title(), label)
                checked += 1
    assert checked >= 2 * 7  # both datasets in every action panel
