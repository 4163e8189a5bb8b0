"""The README's query block is self-contained: its first commands make `datasets/a`, `datasets/b` and
`results/replay-a`, and every line then runs as written, in an empty project folder, through the real CLI."""

from __future__ import annotations

import json
import re
import shlex
from pathlib import Path

import pytest

from tests.support.home import REPO
from tests.support.inproc import run_inproc


def readme_block() -> list[list[str]]:
    text = (REPO / "README.md").read_text()
    block = re.search(r"<!-- stats-sql:begin -->(.*?)<!-- stats-sql:end -->", text, re.S)
    assert block, "README: the stats-sql block is missing"
    return [shlex.split(ln)[1:] for ln in block.group(1).splitlines() if ln.startswith("openral-data ")]


@pytest.mark.slow  # records two datasets and replays one
def test_the_readme_query_block_runs_from_an_empty_folder(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("OPENRAL_DATA_HOME", str(tmp_path))
    lines = readme_block()
    assert [argv[0] for argv in lines[:3]] == ["record", "record", "replay"]  # the inputs come first
    for argv in lines:
        run = run_inproc(*argv, *(["--json"] if argv[0] == "stats" else []))
        assert run.returncode == 0, (argv, run.stderr)
        if argv[0] == "stats":
            rows = json.loads(run.stdout)["sql"]
            assert rows, argv
            assert all(any(v is not None for k, v in r.items() if k != "results") for r in rows), (argv, rows)
    last = json.loads(run_inproc(*lines[-1], "--json").stdout)["sql"]
    assert [r["divergence"] for r in last] == [0.0, 0.0, 0.0]  # an actions replay of a mock run is exact
