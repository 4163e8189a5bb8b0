"""The teleop's status lines and the keys' help talk to a person only: on a terminal, never under -q or --json, and
never before a bad option's one `error:` line; an episode time too long for any episode is refused by its flag's
name (not --max-steps), and 1e308 s is no traceback."""

from __future__ import annotations

import contextlib
import os
import select
from collections.abc import Iterator
from pathlib import Path

import pytest

from openral_data.producers.hal.teleop.keyboard import tty_status
from openral_data.record import hal
from openral_data.schemas.scene import MAX_STEPS
from tests.support.inproc import run_inproc

SPACEMOUSE = ("record", "--scene", "tabletop_push", "--teleop", "spacemouse=/dev/zero", "--codec", "h264")


@contextlib.contextmanager
def _pty_as_status_fd(monkeypatch: pytest.MonkeyPatch) -> Iterator[int]:
    """The run's status fd is a pty (a person's terminal); yields the far side to read what was shown."""
    master, slave = os.openpty()
    monkeypatch.setattr(hal, "STATUS_FD", slave)
    try:
        yield master
    finally:
        os.close(slave)
        os.close(master)


def _shown(master: int) -> bytes:
    text = b""
    while select.select([master], [], [], 0.1)[0]:
        text += os.read(master, 65536)
    return text


def test_status_lines_only_on_a_terminal_of_a_run_that_talks() -> None:
    read, write = os.pipe()
    master, slave = os.openpty()
    try:
        assert tty_status(write) is None  # a pipe, a file: a log, not a person
        assert tty_status(slave, talk=False) is None  # -q, --json
        show = tty_status(slave)
        assert show is not None
        show("eef 0.1 0.2 0.3 gripper open")
        assert _shown(master).startswith(b"\r\x1b[Keef 0.1 0.2 0.3 gripper open\r")  # the pty adds its \r\n
    finally:
        for fd in (read, write, master, slave):
            os.close(fd)


@pytest.mark.parametrize("quiet", [["-q"], ["--json"], ["-q", "--json"], []])
def test_device_status_lines_follow_q_and_json(
    project: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, quiet: list[str]
) -> None:
    """The reviewer's case: `-q record --teleop spacemouse=/dev/zero --episode-time-s 1 --json` left status lines
    on stderr; with a terminal there and the run talking, they are shown."""
    with _pty_as_status_fd(monkeypatch) as master:
        front = ["-q"] if "-q" in quiet else []
        back = ["--json"] if "--json" in quiet else []
        r = run_inproc(*front, *SPACEMOUSE, "--episode-time-s", "0.3", "--out", str(tmp_path / "o"), *back)
        assert r.returncode == 0, r.stderr
        shown = _shown(master)
    assert ("\x1b[K" in r.stderr, b"gripper open" in shown) == (False, not quiet), (r.stderr, shown)


def test_status_lines_never_go_to_a_stderr_that_is_no_terminal(
    project: Path, tmp_path: Path, capfd: pytest.CaptureFixture[str]
) -> None:
    """fd 2 a file (pytest's capture, `2>err`): a talking run writes no status lines to it."""
    r = run_inproc(*SPACEMOUSE, "--episode-time-s", "0.3", "--out", str(tmp_path / "o"))
    assert r.returncode == 0, r.stderr
    fd2 = capfd.readouterr().err
    assert "\x1b[K" not in fd2 and "eef " not in fd2 + r.stderr, fd2  # (the keys help names the gripper)


@pytest.mark.parametrize("seconds", ["1e308", "1e9", str(MAX_STEPS / 20 + 1)])
def test_an_episode_longer_than_any_may_be_is_refused_by_its_flag(project: Path, tmp_path: Path, seconds: str) -> None:
    out = tmp_path / "o"
    r = run_inproc(*SPACEMOUSE, "--episode-time-s", seconds, "--out", str(out))
    assert r.returncode == 2, r.stderr
    line = f"error: --episode-time-s: {float(seconds)} s is more than {MAX_STEPS} frames at 20 fps (an episode's most)"
    assert r.stderr.splitlines() == [line]
    assert not out.exists()


def test_the_longest_episode_is_accepted(project: Path, tmp_path: Path) -> None:
    """`MAX_STEPS / fps` seconds is exactly the limit: it passes the checks (refused later for another reason)."""
    r = run_inproc(*SPACEMOUSE, "--episode-time-s", str(MAX_STEPS / 20), "--seed", "-1", "--out", str(tmp_path))
    assert r.returncode == 2 and "--episode-time-s" not in r.stderr, r.stderr


@pytest.mark.parametrize("bad", [["--episode-time-s", "nan"], ["--reset-time-s", "-1"], ["--fps", "0"]])
def test_bad_input_with_the_keyboard_is_one_line_and_no_keys_help(
    project: Path, tmp_path: Path, bad: list[str]
) -> None:
    out = tmp_path / "o"
    r = run_inproc("record", "--scene", "tabletop_push", "--teleop", "keyboard", *bad, "--out", str(out))
    assert r.returncode == 2, r.stderr
    assert len(r.stderr.splitlines()) == 1 and r.stderr.startswith("error: "), r.stderr
    assert not out.exists()
