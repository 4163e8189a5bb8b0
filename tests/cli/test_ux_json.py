"""JSON the same everywhere: `stats --format json` / `stats --json` one line with `command` and `version`, like
every `--json`; floats rounded to their meaning (cli/jsonout.py), never `2.4000000000000004`."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from openral_data.cli.jsonout import print_json, rounded
from tests.support.inproc import run_inproc
from tests.support.recorded import record_small


def _floats(value: object) -> list[float]:
    if isinstance(value, float):
        return [value]
    if isinstance(value, dict):
        value = list(value.values())
    return [f for v in value for f in _floats(v)] if isinstance(value, list) else []


@pytest.fixture(scope="module")
def dataset(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return record_small(tmp_path_factory.mktemp("json"))


@pytest.mark.parametrize("flag", [["--format", "json"], ["--json"]])
def test_stats_json_is_one_line_like_every_json(dataset: Path, flag: list[str]) -> None:
    run = run_inproc("stats", str(dataset), *flag)
    assert run.returncode == 0, run.stderr
    assert run.stdout.count("\n") == 1 and run.stdout.endswith("\n")
    doc = json.loads(run.stdout)
    assert list(doc)[:2] == ["command", "version"] and doc["command"] == "stats"
    assert doc["groups"][0]["episodes"] == 2
    floats = _floats(doc)
    assert floats and all(f == float(f"{f:.12g}") for f in floats)  # no float keeps arithmetic noise
    info = run_inproc("info", str(dataset), "--json")
    assert info.stdout.count("\n") == 1 and list(json.loads(info.stdout))[:2] == ["command", "version"]


def test_stats_sql_json_is_one_line_too(dataset: Path) -> None:
    sql = "SELECT 0.1::DOUBLE + 0.2::DOUBLE AS x, DATE '2026-01-02' AS d"
    run = run_inproc("stats", str(dataset), "--sql", sql, "--json")
    assert run.returncode == 0, run.stderr
    assert json.loads(run.stdout)["sql"] == [{"x": 0.3, "d": "2026-01-02"}]


def test_every_float_is_rounded_once(capsys: pytest.CaptureFixture[str]) -> None:
    print_json("x", {"a": 0.1 + 0.2, "b": 2.4000000000000004, "tiny": 1.5e-08, "nan": float("nan"), "n": [1 / 3]})
    doc = json.loads(capsys.readouterr().out)
    assert doc["a"] == 0.3 and doc["b"] == 2.4 and doc["tiny"] == 1.5e-08 and doc["nan"] is None
    assert doc["n"] == [0.333333333333]
    assert rounded(95 / 30) == 3.16666666667
