"""`stats` (two datasets: groups, the comparison with its reference named, health) and `info` at 80 and 100
columns, compared with checked-in golden files (tests/cli/golden/); `OPENRAL_DATA_WRITE_GOLDEN=1` writes them
from the current output instead (then review the diff)."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from tests.support.inproc import run_inproc
from tests.support.recorded import record_small

GOLDEN = Path(__file__).parent / "golden"


@pytest.fixture(scope="module")
def work(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """`a/ds` and `b/ds` (2 mock episodes of 3 frames each) moved to `first` and `second`: short relative paths."""
    root = tmp_path_factory.mktemp("widths")
    for name in ("first", "second"):
        record_small(root / f"rec-{name}").rename(root / name)
    return root


def _lines(text: str) -> str:
    return "".join(line.rstrip() + "\n" for line in text.splitlines())


def _golden(name: str, text: str) -> None:
    golden = GOLDEN / name
    if os.environ.get("OPENRAL_DATA_WRITE_GOLDEN") == "1":
        golden.write_text(_lines(text))
    assert _lines(text) == golden.read_text(), f"differs from {golden} (OPENRAL_DATA_WRITE_GOLDEN=1 rewrites it)"


@pytest.mark.parametrize("columns", [80, 100])
def test_stats_and_info_are_the_goldens(work: Path, columns: int, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(work)
    monkeypatch.setenv("COLUMNS", str(columns))
    stats = run_inproc("stats", "second", "first")  # the first given is the reference, not the first by name
    assert stats.returncode == 0, stats.stderr
    assert "comparison with second (success 0.0%; --reference GROUP: another)" in stats.stdout
    assert "(none)" not in stats.stdout
    assert max(len(line) for line in stats.stdout.splitlines()) <= columns
    _golden(f"stats_{columns}.txt", stats.stdout)
    chosen = run_inproc("stats", "second", "first", "--reference", "first")
    assert "comparison with first " in chosen.stdout
    info = run_inproc("info", "first")
    assert info.returncode == 0, info.stderr
    assert max(len(line) for line in info.stdout.splitlines()) <= columns
    _golden(f"info_{columns}.txt", info.stdout)
