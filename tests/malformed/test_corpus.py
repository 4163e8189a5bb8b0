"""Zero tracebacks on malformed input: every case of the corpus exits 2 with one `error:` line naming the file or
option (and field), and leaves every byte already under its folder as it was (tests/malformed/corpus/)."""

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
    c: Case, tmp_path: Path, project: Path, corpus_dataset: Path, corpus_bag: Path, corpus_results: Path
) -> None:
    root = tmp_path / "w"
    root.mkdir()
    args = c.build(Workspace(root, project, corpus_dataset, corpus_bag, corpus_results))
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


@pytest.mark.parametrize("what", ["scenes", "rskills", "robots"])
def test_list_shows_broken_manifests_as_invalid(what: str, project: Path) -> None:
    """`list` is the one command that reads every manifest: a broken one is a row marked invalid, not a crash."""
    broken = {
        "scenes": project / "scenes/sim/zz_broken.yaml",
        "rskills": project / "rskills/zz-broken/rskill.yaml",
        "robots": project / "robots/zz_broken/robot.yaml",
    }[what]
    broken.parent.mkdir(parents=True, exist_ok=True)
    broken.write_bytes(b"id: \xff\xfe\n")
    folder = {
        "scenes": project / "scenes/sim/zz_folder.yaml",
        "rskills": project / "rskills/zz-folder/rskill.yaml",
        "robots": project / "robots/zz_folder/robot.yaml",
    }[what]
    folder.mkdir(parents=True)
    run = run_inproc("list", what)
    assert run.returncode == 0 and "Traceback" not in run.stderr, run.stderr
    assert "zz_broken" in run.stdout.replace("-", "_") and "invalid" in run.stdout
