"""Closing summaries fit the terminal and `-q` silences them: `convert` (bags -> LeRobot) continues a long row
under itself at 80 columns (one greppable line per row when piped without `$COLUMNS`), `episodes trim`
says what it cut within 100 columns, and under `-q` both print nothing on stdout (their outputs still written)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from tests.support.bags import MAPPING, write_ros2
from tests.support.cli import run_cli
from tests.support.inproc import run_inproc
from tests.support.recorded import record_small
from tests.support.scenes import write_yaml


@pytest.fixture(scope="module")
def work(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A folder with a small rosbag2 (`b`) and its mapping (`m.yaml`): short relative paths in the summaries."""
    root = tmp_path_factory.mktemp("summaries")
    write_ros2(root / "b", "mcap", duration_ms=300)
    write_yaml(root / "m.yaml", MAPPING)
    return root


def _rows(stdout: str) -> dict[str, str]:
    """The summary's rows, each continuation line joined to its row."""
    rows: dict[str, str] = {}
    key = ""
    for line in stdout.splitlines()[1:]:
        head, _, value = line.strip().partition("  ")
        if line[2] != " ":  # a row of its own: `  key  value`
            key = head
            rows[key] = value.strip()
        else:  # continued under the value
            rows[key] += " " + line.strip()
    return rows


def test_the_convert_summary_fits_and_says_the_same(work: Path) -> None:
    columns = 80  # (and so 100)
    out = f"out{columns}"
    done = run_cli(
        "convert", "b", out, "--mapping", "m.yaml", "--codec", "h264", cwd=work, env={"COLUMNS": str(columns)}
    )
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    assert max(len(line) for line in lines) <= columns
    assert any(line.startswith(" " * 10) for line in lines)  # a long row continued under its value
    piped = run_cli("convert", "b", out + "p", "--mapping", "m.yaml", "--codec", "h264", cwd=work, env={"COLUMNS": ""})
    assert max(len(line) for line in piped.stdout.splitlines()) > 100  # a log keeps one line per row
    wrapped, whole = _rows(done.stdout), _rows(piped.stdout)
    assert wrapped.pop("output") == out and whole.pop("output") == out + "p"
    assert wrapped.keys() == whole.keys() and wrapped.pop("frames/s") and whole.pop("frames/s")
    assert wrapped == whole  # the same words, wrapped
    assert whole["unfillable frames"].startswith("0 skipped, never zero-filled")


def test_quiet_silences_the_summaries(work: Path) -> None:
    done = run_cli("-q", "convert", "b", "outq", "--mapping", "m.yaml", "--codec", "h264", cwd=work)
    assert done.returncode == 0 and done.stdout == "", done.stdout + done.stderr
    assert json.loads((work / "outq/meta/info.json").read_text())["total_episodes"] >= 1
    small = record_small(work / "rec")  # 2 episodes of 3 frames
    trimmed = run_inproc("-q", "episodes", "trim", str(small), "--frames", "0:0-1", "--out", str(work / "t"))
    assert trimmed.returncode == 0 and trimmed.stdout == "", trimmed.stdout + trimmed.stderr
    assert json.loads((work / "t/meta/info.json").read_text())["total_frames"] == 4
    said = run_inproc("episodes", "trim", str(small), "--frames", "0:0-1", "--out", str(work / "t2")).stdout
    lines = said.splitlines()
    assert lines[1] == "trimmed: 1 episodes, 2 frames dropped"
    assert lines[2].startswith("trimmed: camera clips: ") and len(lines[2]) <= 100
