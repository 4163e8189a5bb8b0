"""`list scenes|rskills|robots` at 100 columns, compared with checked-in golden files (tests/cli/golden/):
ids whole on a line of their own, nothing wider than the terminal, every entry that cannot run here marked with a
numbered reason. `OPENRAL_DATA_WRITE_GOLDEN=1` writes the files from the current output instead (then review the
diff)."""

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
    monkeypatch.setenv("COLUMNS", "100")


def _lines(text: str) -> str:
    return "".join(line.rstrip() + "\n" for line in text.splitlines())


@pytest.mark.parametrize("kind", KINDS)
def test_list_at_100_columns_is_the_golden(kind: str) -> None:
    pytest.importorskip("gym_pusht")  # the golden is this repository's environment (scripts/setup.sh's extras)
    run = run_inproc("list", kind)
    assert run.returncode == 0, run.stderr
    golden = GOLDEN / f"list_{kind}_100.txt"
    if os.environ.get("OPENRAL_DATA_WRITE_GOLDEN") == "1":
        golden.write_text(_lines(run.stdout))
    assert _lines(run.stdout) == golden.read_text(), f"differs from {golden} (OPENRAL_DATA_WRITE_GOLDEN=1 rewrites it)"


@pytest.mark.parametrize("kind", KINDS)
def test_list_keeps_ids_whole_and_says_why_not(kind: str) -> None:
    run = run_inproc("list", kind)
    assert run.returncode == 0, run.stderr
    lines = run.stdout.splitlines()
    assert max(len(line) for line in lines) <= 100
    listed = json.loads(run_inproc("list", kind, "--json").stdout)[kind]
    assert listed and all(entry["id"] in lines for entry in listed)  # each id whole, on a line of its own
    notes = {m.group(1) for line in lines if (m := re.fullmatch(r"\s*runs here\s+no \((\d+)\)", line))}
    for note in notes:  # every "no (N)" has its reason below
        assert any(re.fullmatch(rf"\({note}\) \S.*", line) for line in lines), note
