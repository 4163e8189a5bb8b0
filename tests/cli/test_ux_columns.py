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
comparison: (none)
health: (none)
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


def test_list_never_cuts_an_id_and_says_what_cannot_run(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("COLUMNS", "100")
    run = run_inproc("list", "rskills")
    assert run.returncode == 0, run.stderr
    assert max(len(line) for line in run.stdout.splitlines()) <= 100
    ids = [line.split()[0] for line in run.stdout.splitlines() if line.startswith(" ") and line.split()]
    for rskill in ("lerobot-act-push", "robosuite-panda-random", "scripted-open-drawer", "sweep-ur5e"):
        assert rskill in ids
    row = next(line for line in run.stdout.splitlines() if line.startswith(" lerobot-act-push "))
    note = re.search(r"no \((\d)\)", row)
    assert note is not None
    assert f"({note.group(1)}) neural rSkills need their checkpoint" in run.stdout
    assert "/rskill.yaml" not in run.stdout  # paths only with --paths
    assert re.search(r" path *$", run_inproc("list", "rskills", "--paths").stdout, re.M)


def test_list_scenes_marks_libero_when_its_environment_is_absent(monkeypatch: pytest.MonkeyPatch) -> None:
    pytest.importorskip("gym_pusht")
    monkeypatch.setenv("COLUMNS", "100")
    run = run_inproc("list", "scenes")
    lines = run.stdout.splitlines()
    assert any(line.startswith(" libero_spatial_bench ") for line in lines)  # the longest ids whole
    assert any(line.startswith(" metaworld_button_press_topdown_bench ") for line in lines)
    pusht = next(line for line in lines if line.startswith(" pusht "))
    assert pusht.rstrip().endswith("yes")
    try:
        import libero  # noqa: F401
    except ImportError:
        libero_row = next(line for line in lines if line.startswith(" libero_10 "))
        assert re.search(r"no \(\d\)", libero_row)
        assert "libero scenes: needs their own environment (bash scripts/setup_libero.sh)" in run.stdout
