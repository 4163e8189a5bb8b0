"""Readable at 100 columns: the compact `stats` default (golden), vertical records for a table wider than the
terminal, and `list` never cutting an id while it marks what cannot run here."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from tests.support.inproc import run_inproc
from tests.support.recorded import record_small

STATS_100 = """\
groups
┏━━━━━━━━━┳━━━━━━━━━━┳━━━━━━━━┳━━━━━━━━━━━━┳━━━━━━━━━━━━━━━┳━━━━━━━━━━━━━━━┓
┃ dataset ┃ episodes ┃ frames ┃ success    ┃ 95% interval  ┃ median length ┃
┡━━━━━━━━━╇━━━━━━━━━━╇━━━━━━━━╇━━━━━━━━━━━━╇━━━━━━━━━━━━━━━╇━━━━━━━━━━━━━━━┩
│ ds      │ 2        │ 6      │ 0/2 = 0.0% │ 0.0% .. 65.8% │ 3             │
└─────────┴──────────┴────────┴────────────┴───────────────┴───────────────┘
health: no problems found
(dimensions, sources, quality and every column: --all)
"""


@pytest.fixture(scope="module")
def dataset(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return record_small(tmp_path_factory.mktemp("columns"))


def _lines(text: str) -> str:
    return "".join(line.rstrip() + "\n" for line in text.splitlines())


def test_stats_default_is_compact_at_100_columns(dataset: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("COLUMNS", "100")
    run = run_inproc("stats", str(dataset))
    assert run.returncode == 0, run.stderr
    assert _lines(run.stdout) == STATS_100
    assert max(len(line) for line in run.stdout.splitlines()) <= 100


def test_stats_all_prints_every_table_within_100_columns(dataset: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("COLUMNS", "100")
    run = run_inproc("stats", str(dataset), "--all")
    assert run.returncode == 0, run.stderr
    for table in ("comparison", "dimensions", "sources", "health", "quality"):
        assert re.search(rf"^{table}( \[0\])?\s*$", run.stdout, re.M), table
    assert "groups [0]\n  dataset        ds\n  episodes       2\n" in run.stdout  # too wide: a vertical record
    assert "ci95_high      0.6576" in run.stdout
    assert max(len(line) for line in run.stdout.splitlines()) <= 100


def _row(text: str, entry: str) -> list[str]:
    """One entry of `list`'s grid: its cells (split on runs of two or more spaces)."""
    line = next(line for line in text.splitlines() if line.split(" ", 1)[0] == entry)
    return re.split(r"\s{2,}", line.strip())


def test_list_never_cuts_an_id_and_says_what_cannot_run(monkeypatch: pytest.MonkeyPatch) -> None:
    """A grid within 100 columns (cells cut with a note where needed, never an id); --paths adds the file."""
    monkeypatch.setenv("COLUMNS", "100")
    run = run_inproc("list", "rskills")
    assert run.returncode == 0, run.stderr
    assert max(len(line) for line in run.stdout.splitlines()) <= 100
    for rskill in ("lerobot-act-push", "robosuite-panda-random", "scripted-open-drawer", "sweep-ur5e"):
        assert _row(run.stdout, rskill)[0] == rskill  # whole, first on its line
    note = re.fullmatch(r"no \((\d)\)", _row(run.stdout, "lerobot-act-push")[-1])
    assert note is not None
    assert f"({note.group(1)}) neural rSkills need their checkpoint" in run.stdout
    assert "/rskill.yaml" not in run.stdout  # paths only with --paths
    monkeypatch.setenv("COLUMNS", "400")
    assert _row(run_inproc("list", "rskills", "--paths").stdout, "sweep-ur5e")[-1].endswith("rskill.yaml")


def test_list_scenes_marks_libero_when_its_environment_is_absent(monkeypatch: pytest.MonkeyPatch) -> None:
    pytest.importorskip("gym_pusht")
    monkeypatch.setenv("COLUMNS", "100")
    run = run_inproc("list", "scenes")
    assert _row(run.stdout, "metaworld_button_press_topdown")[0] == "metaworld_button_press_topdown"  # whole
    assert _row(run.stdout, "pusht")[-1] == "yes"
    assert "libero_spatial_bench" in run_inproc("list", "scenes", "--all").stdout
    try:
        import libero  # noqa: F401
    except ImportError:
        assert re.fullmatch(r"no \(\d\)", _row(run.stdout, "libero_10")[-1])
        assert "libero scenes: needs their own environment (bash scripts/setup_libero.sh)" in run.stdout
