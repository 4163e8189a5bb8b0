"""One small recorded dataset and one small bag, made once and copied by every case that needs them."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.support.bags import write_plain_mcap
from tests.support.home import isolated_home
from tests.support.inproc import run_inproc


@pytest.fixture(scope="session")
def corpus_dataset(tmp_path_factory: pytest.TempPathFactory) -> Path:
    base = tmp_path_factory.mktemp("corpus_dataset")
    out = base / "ds"
    with isolated_home(base):
        run = run_inproc("record", "--n-episodes", "2", "--max-steps", "3", "--codec", "h264", "--out", str(out))
    assert run.returncode == 0, run.stderr
    return out


@pytest.fixture(scope="session")
def corpus_results(tmp_path_factory: pytest.TempPathFactory, corpus_dataset: Path) -> Path:
    base = tmp_path_factory.mktemp("corpus_results")
    with isolated_home(base):
        run = run_inproc("replay", str(corpus_dataset), "--out", str(base / "res"))
    assert run.returncode == 0, run.stderr
    return base / "res"


@pytest.fixture(scope="session")
def corpus_bag(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return write_plain_mcap(tmp_path_factory.mktemp("corpus_bag") / "log.mcap", duration_ms=400)
