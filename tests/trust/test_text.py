"""Dataset text is data (#29, class 8, and the markup tracebacks of class 7): a task or feature key holding rich
markup (`[/]`, `[bold]`), emoji codes (`:x:`), terminal sequences (an OSC 8 link, `ESC [2J`) or line breaks is
shown literally, its controls escaped, by every command that prints it and in the Hub card; never a traceback,
never a raw ESC byte on stdout or stderr."""

from __future__ import annotations

import json
import logging
import shutil
from pathlib import Path

import pytest

from openral_data.cli.logs import PrintableFormatter, TextFormatter
from openral_data.text import printable
from tests.support.inproc import Run, run_inproc
from tests.support.recorded import record_small

EVIL_TASK = "go [/] [bold]x:x: \x1b]8;;http://evil\x07link\x1b]8;;\x07 \x1b[2J\nforged: line"
EVIL_KEY = "observation.images.fr\x1b[2Jont"  # a camera key with a control sequence
CAMERA = "observation.images.front"


@pytest.fixture(scope="module")
def evil(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A recorded mock dataset whose one task is EVIL_TASK (set through `tasks rename`, so it stays healthy)."""
    base = tmp_path_factory.mktemp("evil_text")
    ds = record_small(base)
    renamed = run_inproc(
        "tasks", "rename", str(ds), "--from", "pick up the mock cube", "--to", EVIL_TASK, "--out", str(base / "evil")
    )
    assert renamed.returncode == 0, renamed.stderr
    return base / "evil"


@pytest.fixture(scope="module")
def evil_key(evil: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """`evil` with its front camera's key in info.json renamed to EVIL_KEY."""
    root = tmp_path_factory.mktemp("evil_key") / "ds"
    shutil.copytree(evil, root)
    info_path = root / "meta" / "info.json"
    info = json.loads(info_path.read_text())
    info["features"][EVIL_KEY] = info["features"].pop(CAMERA)
    info_path.write_text(json.dumps(info))
    return root


def _no_raw_controls(run: Run) -> None:
    assert "Traceback" not in run.stderr, run.stderr
    for stream in (run.stdout, run.stderr):
        assert "\x1b" not in stream and "\x07" not in stream
        assert "\u274c" not in stream  # `:x:` was not turned into an emoji


@pytest.mark.parametrize(
    "args",
    [
        ("info", "{ds}"),
        ("tasks", "list", "{ds}"),
        ("stats", "report", "{ds}", "--by", "task"),
        ("stats", "report", "{ds}", "--sql", "SELECT task FROM tasks"),
        ("stats", "report", "{ds}", "--sql", "SELECT task FROM tasks", "--format", "markdown"),
        ("push", "{ds}", "someone/evil", "--dry-run"),
    ],
    ids=["info", "tasks-list", "stats-by-task", "stats-sql", "stats-sql-markdown", "push-card"],
)
def test_task_text_is_shown_literally(evil: Path, args: tuple[str, ...]) -> None:
    run = run_inproc(*(a.format(ds=evil) for a in args))
    assert run.returncode == 0, run.stderr
    _no_raw_controls(run)
    # literal: the markup and the emoji code as written, the controls escaped (a table may fold the long cell)
    assert "go [/] [bold]x:x: " in run.stdout
    assert "\\x1b]8;;http://evil\\x07link" in run.stdout and "\\x1b[2J" in run.stdout
    assert "\nforged: line" not in run.stdout  # the line break did not start a line of its own


def test_feature_key_is_shown_escaped(evil_key: Path) -> None:
    run = run_inproc("info", str(evil_key))
    assert run.returncode == 0, run.stderr
    _no_raw_controls(run)
    assert "observation.images.fr\\x1b[2Jont" in run.stdout


def test_error_line_quoting_dataset_text_has_no_controls(evil_key: Path, tmp_path: Path) -> None:
    run = run_inproc("features", "remove", str(evil_key), "--feature", "nope", "--out", str(tmp_path / "out"))
    assert run.returncode == 2
    _no_raw_controls(run)
    assert run.stderr.count("\n") == 1 and run.stderr.startswith("error: ")
    assert "observation.images.fr\\x1b[2Jont" in run.stderr


def test_doctor_finding_quoting_dataset_text_stays_one_line(evil_key: Path) -> None:
    run = run_inproc("doctor", str(evil_key))
    _no_raw_controls(run)
    assert "observation.images.fr\\x1b[2Jont" in run.stdout


def test_printable_leaves_good_text_alone() -> None:
    good = "pick up the red cube → 赤いキューブ 🤖 [1/2] a\\b"
    assert printable(good) == good
    assert printable("a\nb\tc\x1b\x7f\x9b\u202e") == "a\\nb\\tc\\x1b\\x7f\\x9b\\u202e"
    assert printable("a\nb\x1b", keep_newlines=True) == "a\nb\\x1b"


@pytest.mark.parametrize("formatter", [TextFormatter(), PrintableFormatter()], ids=["text", "rich"])
def test_log_records_quoting_dataset_text_are_escaped(formatter: logging.Formatter) -> None:
    record = logging.LogRecord("openral_data.test", logging.WARNING, __file__, 1, "task %s", (EVIL_TASK,), None)
    line = formatter.format(record)
    assert "\x1b" not in line and "\x07" not in line and "\\x1b[2J" in line


def test_json_output_escapes_the_controls_json_leaves_raw(evil: Path, tmp_path: Path) -> None:
    """JSON escapes C0 itself; C1 (`\\x9b` is a one-byte CSI), DEL and the bidi overrides it leaves raw unless
    `--json` escapes them too: the document reads back the same."""
    task = "c1 \x9b2J del \x7f bidi \u202etxt.exe"
    out = tmp_path / "c1"
    run = run_inproc("tasks", "rename", str(evil), "--from", EVIL_TASK, "--to", task, "--out", str(out))
    assert run.returncode == 0, run.stderr
    run = run_inproc("tasks", "list", str(out), "--json")
    assert run.returncode == 0, run.stderr
    assert not any(c in run.stdout for c in "\x9b\x7f\u202e"), run.stdout
    assert [t["task"] for t in json.loads(run.stdout)["tasks"]] == [task]
