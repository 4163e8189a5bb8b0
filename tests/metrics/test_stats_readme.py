"""The `--sql` examples of the README, run verbatim (only the dataset/results paths are substituted)."""

from __future__ import annotations

import json
import re
import shlex
from collections.abc import Iterator

import pytest

from openral_data.metrics.command import StatsOptions, run_stats
from tests.support.cli import run_cli
from tests.support.home import REPO
from tests.support.metrics import A_SUCCESS_AFTER, B_SUCCESS_AFTER, MAX_STEPS, record_datasets
from tests.support.results import make_results


def readme_examples() -> list[list[str]]:
    text = (REPO / "README.md").read_text()
    block = re.search(r"<!-- stats-sql:begin -->(.*?)<!-- stats-sql:end -->", text, re.S)
    assert block, "README: the stats-sql block is missing"
    lines = [ln for ln in block.group(1).splitlines() if ln.startswith("openral-data stats ")]
    return [shlex.split(ln)[1:] for ln in lines]


EXAMPLES = readme_examples()


@pytest.fixture(scope="module")
def paths(tmp_path_factory: pytest.TempPathFactory) -> Iterator[dict[str, str]]:
    base = tmp_path_factory.mktemp("readme")
    a, b = record_datasets(base)
    res, _ = make_results(a, base / "replay-a")
    yield {"datasets/a": str(a), "datasets/b": str(b), "results/replay-a": str(res)}


def _run(argv: list[str], paths: dict[str, str]) -> list[dict[str, object]]:
    assert argv[0] == "stats"
    sql = argv[argv.index("--sql") + 1]
    inputs = [paths[p] for p in argv[1 : argv.index("--sql")]]
    rows: list[dict[str, object]] = json.loads(run_stats(StatsOptions(inputs, sql=sql, fmt="json")))["sql"]
    return rows


def test_there_are_examples() -> None:
    assert len(EXAMPLES) >= 6


@pytest.mark.parametrize("argv", EXAMPLES, ids=[f"example{i + 1}" for i in range(len(EXAMPLES))])
def test_readme_example_runs(argv: list[str], paths: dict[str, str]) -> None:
    rows = _run(argv, paths)
    assert rows, argv


def test_readme_examples_answer_correctly(paths: dict[str, str]) -> None:
    by_rskill = _run(EXAMPLES[0], paths)
    assert [(r["rskill"], r["episodes"]) for r in by_rskill] == [
        ("random-mock", len(A_SUCCESS_AFTER)),
        ("zero-mock", len(B_SUCCESS_AFTER)),
    ]
    a_rate = sum(x <= MAX_STEPS for x in A_SUCCESS_AFTER) / len(A_SUCCESS_AFTER)
    assert by_rskill[0]["success_rate"] == pytest.approx(a_rate)
    longest = _run(EXAMPLES[1], paths)
    assert all(r["length"] == MAX_STEPS for r in longest)
    succeeded = _run(EXAMPLES[3], paths)
    expected = sum(x <= MAX_STEPS for x in A_SUCCESS_AFTER + B_SUCCESS_AFTER)
    assert len(succeeded) == expected
    assert all(
        r["frame_index"] == min(A_SUCCESS_AFTER[int(str(r["episode_index"]))], MAX_STEPS) - 1
        for r in succeeded
        if str(r["dataset"]).endswith("mock_a")
    )


def test_readme_example_through_the_cli(paths: dict[str, str]) -> None:
    argv = [paths.get(x, x) for x in EXAMPLES[0]]
    proc = run_cli(*argv, "--format", "csv")
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.splitlines()[0] == "rskill,episodes,success_rate"
