"""`-v/-vv/-q/--log-format`: the real CLI logs a recording's timings on stderr (text, rich on a terminal, or one
JSON object per line), stdout stays the command's output, `-q` leaves only warnings and hides the progress bar."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from tests.support.cli import run_cli
from tests.support.scenes import mock_scene, write_yaml

SUCCESS_AFTER = [3, 99]  # episode 0 succeeds at step 3, episode 1 is cut at MAX_STEPS
MAX_STEPS = 5
TIMING = ("seconds", "frames_per_s")  # the only fields of `record --json` that differ run to run
JSON_KEYS = ["time", "level", "logger", "message"]


def _record(
    project: Path, out: Path, *flags: str, json_out: bool = True, env: dict[str, str] | None = None
) -> tuple[int, str, str]:
    """`openral-data FLAGS... record ... [--json]` on a two-episode mock scene."""
    scene = write_yaml(
        project / "scenes/sim/mock_logs.yaml",
        mock_scene(scene_id="mock_logs", success_after=SUCCESS_AFTER, max_steps=MAX_STEPS, n_episodes=2),
    )
    args = [*flags, "record", "--scene", str(scene), "--rskill", "random-mock", "--out", str(out), "--codec", "h264"]
    proc = run_cli(*args, *(["--json"] if json_out else []), env=env)
    return proc.returncode, proc.stdout, proc.stderr


def _doc(stdout: str) -> dict[str, Any]:
    lines = stdout.splitlines()
    assert len(lines) == 1, stdout  # still exactly one document
    doc: dict[str, Any] = json.loads(lines[0])
    for key in ("out", *TIMING):
        doc.pop(key)
    return doc


def test_verbose_logs_the_timings_on_stderr_and_leaves_stdout_alone(project: Path, tmp_path: Path) -> None:
    code, quiet_out, quiet_err = _record(project, tmp_path / "plain")
    assert code == 0 and quiet_err == ""  # nothing logged by default (WARNING) when all is well
    code, out, err = _record(project, tmp_path / "verbose", "-v")
    assert code == 0
    assert _doc(out) == _doc(quiet_out)  # same document; the logs went to stderr
    lines = err.splitlines()
    assert not any("DEBUG" in line for line in lines)  # -v is INFO
    start = [line for line in lines if "started in" in line]
    assert len(start) == 1 and all(f" {k}=" in start[0] for k in ("env_ms", "policy_ms", "total_ms"))
    assert "concurrent=True" in start[0]
    for index, length, outcome in ((0, 3, "success"), (1, MAX_STEPS, "failure")):
        [episode] = [line for line in lines if f"episode={index} seed={index} length=" in line]
        assert f"length={length} outcome={outcome} seconds=" in episode
        [commit] = [line for line in lines if f"episode {index} committed in" in line]
        assert all(f" {k}=" in commit for k in ("flush_ms", "commit_ms", "encoder_wait_ms", "encoder_waits"))
    [totals] = [line for line in lines if "saved=" in line]
    assert f"saved=2 frames={3 + MAX_STEPS} " in totals


def test_log_format_json_is_one_object_per_stderr_line(project: Path, tmp_path: Path) -> None:
    code, out, err = _record(project, tmp_path / "ds", "-vv", "--log-format", "json")
    assert code == 0
    doc = json.loads(out)  # stdout: the one --json document, untouched
    records = [json.loads(line) for line in err.splitlines()]  # every stderr line parses
    assert records and all(list(r)[:4] == JSON_KEYS for r in records)
    assert {r["level"] for r in records} == {"INFO", "DEBUG"}  # -vv adds DEBUG (the per-camera encoder waits)
    [start] = [r for r in records if "total_ms" in r]
    assert start["logger"] == "openral_data.record.start" and start["concurrent"] is True
    assert all(isinstance(start[k], float) and start[k] >= 0 for k in ("env_ms", "policy_ms", "total_ms"))
    assert start["total_ms"] >= max(start["env_ms"], start["policy_ms"]) - 1  # both ran within the start
    episodes = [r for r in records if "outcome" in r]
    assert [{k: r[k] for k in ("episode", "seed", "length")} for r in episodes] == [
        {"episode": e["index"], "seed": e["seed"], "length": e["length"]} for e in doc["episode_list"]
    ]
    assert [r["outcome"] for r in episodes] == ["success", "failure"]
    commits = [r for r in records if "commit_ms" in r]
    assert [r["episode"] for r in commits] == [0, 1] and all(r["encoder_waits"] >= 0 for r in commits)
    cameras = [(r["episode"], r["camera"]) for r in records if r["level"] == "DEBUG" and "camera" in r]
    assert cameras == [(0, "front"), (0, "wrist"), (1, "front"), (1, "wrist")]
    [totals] = [r for r in records if "saved" in r]
    assert (totals["saved"], totals["frames"], totals["out"]) == (2, doc["frames"], doc["out"])


@pytest.mark.parametrize("flag", ["-v", "-q"])
def test_quiet_hides_the_progress_bar_and_info_on_a_terminal(project: Path, tmp_path: Path, flag: str) -> None:
    """FORCE_COLOR makes rich treat stderr as a terminal: the bar and rich's log lines show, unless -q."""
    code, out, err = _record(project, tmp_path / "ds", flag, json_out=False, env={"FORCE_COLOR": "1"})
    assert code == 0 and ("recorded" in out) == (flag == "-v")  # -q: no closing summary either
    if flag == "-q":
        assert err == ""
    else:
        assert "recording" in err and "INFO" in err and "started in" in err


def test_verbose_and_quiet_together_are_one_line() -> None:
    proc = run_cli("-v", "-q", "list")
    assert proc.returncode == 2 and proc.stdout == ""
    assert proc.stderr.splitlines() == ["error: -v/--verbose and -q/--quiet: choose one"]
