"""Long work shows progress: the editing commands tick `formats.progress` once per episode written and
`doctor --deep` once per video file, through the CLI's lazy progress bar (stderr, a terminal only; none with
`-q` or `--json`)."""

from __future__ import annotations

import io
from pathlib import Path

import pytest
from rich.console import Console

from openral_data.cli import globalflags, terminal
from tests.support.inproc import run_inproc
from tests.support.recorded import record_small

TICKS: list[tuple[int, int]] = []


class Recording(terminal.LazyBar):
    def __call__(self, done: int, total: int) -> None:
        TICKS.append((done, total))
        super().__call__(done, total)


@pytest.fixture(scope="module")
def dataset(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return record_small(tmp_path_factory.mktemp("progress"))


@pytest.fixture(autouse=True)
def recording(monkeypatch: pytest.MonkeyPatch) -> None:
    TICKS.clear()
    monkeypatch.setattr(globalflags, "LazyBar", Recording)


@pytest.mark.parametrize(
    "args",
    [
        ["episodes", "filter", "{ds}", "--where", "episode_index >= 0", "--out", "{tmp}/f"],
        ["stats", "recompute", "{ds}", "--out", "{tmp}/r"],
        ["videos", "reencode", "{ds}", "--codec", "h264", "--out", "{tmp}/v", "-q"],
    ],
)
def test_editing_commands_report_each_episode(dataset: Path, tmp_path: Path, args: list[str]) -> None:
    run = run_inproc(*(a.format(ds=dataset, tmp=tmp_path) for a in args))
    assert run.returncode == 0, run.stderr
    assert TICKS == [(1, 2), (2, 2)]
    assert "writing" not in run.stderr  # not a terminal: the bar itself stays silent


def test_doctor_deep_reports_each_video_file(dataset: Path) -> None:
    run = run_inproc("doctor", str(dataset), "--deep")
    assert run.returncode == 0, run.stderr
    assert TICKS and TICKS[-1][0] == TICKS[-1][1] == len(TICKS)
    TICKS.clear()
    assert run_inproc("doctor", str(dataset)).returncode == 0
    assert TICKS == []


def test_json_and_other_commands_get_no_progress(dataset: Path, tmp_path: Path) -> None:
    assert run_inproc("info", str(dataset)).returncode == 0
    run = run_inproc("record", "--n-episodes", "1", "--max-steps", "2", "--out", str(tmp_path / "r"), "--json")
    assert run.returncode == 0, run.stderr
    assert TICKS == []


def test_the_bar_draws_on_a_terminal_and_not_with_q(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(terminal, "err_console", Console(file=io.StringIO(), force_terminal=True))
    shown = terminal.LazyBar("writing", "episodes")
    shown(1, 2)
    assert shown.bar is not None and not shown.bar.disable
    shown.close()
    monkeypatch.setattr(terminal, "json_output", True)  # what `--json` sets
    scripted = terminal.LazyBar("writing", "episodes")
    scripted(1, 2)
    assert scripted.bar is not None and scripted.bar.disable
    scripted.close()
    monkeypatch.setattr(terminal, "json_output", False)
    monkeypatch.setattr(terminal, "quiet", True)
    hidden = terminal.LazyBar("writing", "episodes")
    hidden(1, 2)
    assert hidden.bar is not None and hidden.bar.disable
    hidden.close()


def test_a_quiet_or_json_run_in_process_leaves_the_next_runs_bar_on(dataset: Path) -> None:
    """`-q` and `--json` hold for their own run only: an in-process caller's (or a test worker's) next run starts
    with the bar on, as a fresh process would."""
    for args in (["-q", "info", str(dataset)], ["info", str(dataset), "--json"]):
        r = run_inproc(*args)
        assert r.returncode == 0, r.stderr
        assert not terminal.quiet and not terminal.json_output, args
