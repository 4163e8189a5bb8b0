"""`list scenes|rskills|robots` at 80 and 100 columns, compared with checked-in golden files (tests/cli/golden/):
a grid (the main columns; `--all` adds the benchmark copies and the other columns) whose ids are never cut, nothing
wider than the terminal, a cut cell marked, every entry that cannot run here marked with a numbered reason.
`OPENRAL_DATA_WRITE_GOLDEN=1` writes the files from the current output instead (then review the diff)."""

from __future__ import annotations

import json
import os
import re
from pathlib import Path

import pytest

from tests.support.inproc import run_inproc

GOLDEN = Path(__file__).parent / "golden"
KINDS = ["scenes", "rskills", "robots"]


@pytest.fixture(autouse=True)
def only_builtin_manifests(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """An empty project and user config: the listing is the package's own manifests."""
    monkeypatch.setenv("OPENRAL_DATA_HOME", str(tmp_path))
    monkeypatch.setenv("OPENRAL_DATA_CONFIG", str(tmp_path / "config"))


def _lines(text: str) -> str:
    return "".join(line.rstrip() + "\n" for line in text.splitlines())


@pytest.mark.parametrize("columns", [80, 100])
@pytest.mark.parametrize("kind", KINDS)
def test_list_is_the_golden(kind: str, columns: int, monkeypatch: pytest.MonkeyPatch) -> None:
    pytest.importorskip("gym_pusht")  # the golden is this repository's environment (scripts/setup.sh's extras)
    monkeypatch.setenv("COLUMNS", str(columns))
    run = run_inproc("list", kind)
    assert run.returncode == 0, run.stderr
    golden = GOLDEN / f"list_{kind}_{columns}.txt"
    if os.environ.get("OPENRAL_DATA_WRITE_GOLDEN") == "1":
        golden.write_text(_lines(run.stdout))
    assert _lines(run.stdout) == golden.read_text(), f"differs from {golden} (OPENRAL_DATA_WRITE_GOLDEN=1 rewrites it)"


@pytest.mark.parametrize("columns", [80, 100])
@pytest.mark.parametrize("kind", KINDS)
def test_list_fits_keeps_ids_whole_and_says_why_not(kind: str, columns: int, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("COLUMNS", str(columns))
    run = run_inproc("list", kind)
    assert run.returncode == 0, run.stderr
    lines = run.stdout.splitlines()
    assert max(len(line) for line in lines) <= columns
    assert lines[1].split()[0] == "id" and len(lines) < 40  # a grid, one line per entry, not records
    listed = json.loads(run_inproc("list", kind, "--json").stdout)[kind]
    firsts = {line.split()[0] for line in lines[3:] if line.strip()}
    bench = {e["id"] for e in listed if e.get("tier") == "benchmark"}
    assert {e["id"] for e in listed} - bench <= firsts  # every id whole, first on its line
    assert not bench & firsts  # the benchmark copies only with --all ...
    if bench:
        assert f"(--all: also {len(bench)} benchmark copies (*_bench)" in run.stdout
        assert bench <= {line.split()[0] for line in run_inproc("list", kind, "--all").stdout.splitlines() if line}
    if "…" in run.stdout:  # a cut cell is said so
        assert f"(… : a cell cut to fit {columns} columns; --json shows every cell whole)" in lines
    notes = {m.group(1) for line in lines if (m := re.search(r"\sno \((\d+)\)\s*$", line))}
    for note in notes:  # every "no (N)" has its reason below
        assert any(re.fullmatch(rf"\({note}\) \S.*", line) for line in lines), note


def test_a_mistyped_kind_gets_the_closest_one() -> None:
    run = run_inproc("list", "scnes")
    assert run.returncode == 2
    assert run.stderr.startswith("error: list: 'scnes' is not one of 'all', 'scenes',")
    assert run.stderr.rstrip().endswith("; did you mean 'scenes'?") and "what" not in run.stderr
