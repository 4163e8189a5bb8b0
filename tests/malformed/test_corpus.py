"""Zero tracebacks on malformed input: every case of the corpus exits 2 with one `error:` line naming the file or
option (and field), and leaves every byte already under its folder as it was (tests/malformed/corpus.py)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from tests.malformed.corpus import CASES, Case
from tests.support.inproc import run_inproc
from tests.support.malformed import Workspace, snapshot


def test_the_corpus_is_large_enough() -> None:
    assert len(CASES) >= 200


@pytest.mark.parametrize("c", CASES, ids=[c.id for c in CASES])
def test_malformed_input_is_one_line(
    c: Case, tmp_path: Path, project: Path, corpus_dataset: Path, corpus_bag: Path
) -> None:
    root = tmp_path / "w"
    root.mkdir()
    args = c.build(Workspace(root, project, corpus_dataset, corpus_bag))
    before = snapshot(tmp_path)
    run = run_inproc(*args)
    assert "Traceback" not in run.stderr, run.stderr
    lines = [ln for ln in run.stderr.splitlines() if ln.strip()]
    assert run.returncode == 2, (run.returncode, run.stdout, run.stderr)
    assert len(lines) == 1, run.stderr
    assert lines[0].startswith("error: "), lines[0]
    assert re.search(c.names, lines[0]), (c.names, lines[0])
    for rel in c.new:
        assert not (root / rel).exists(), f"{rel} was written"
    assert snapshot(tmp_path) == before
