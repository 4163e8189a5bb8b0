"""An operator's verdict the scene's criterion contradicts: both are stored, the disagreement is said when the
episode ends, and `replay` explains the success it cannot reproduce although nothing diverged."""

from __future__ import annotations

import json
from pathlib import Path

from tests.support.hal import episode_infos
from tests.support.inproc import run_inproc

# a space mouse that never moves (/dev/zero: every report all zeros) on the push scene: the cube stays put
RECORD = ("record", "--scene", "tabletop_push", "--teleop", "spacemouse=/dev/zero", "--codec", "h264")


def test_a_success_the_scene_denies_is_stored_with_both_verdicts_said_and_explained(
    project: Path, tmp_path: Path
) -> None:
    out, res = tmp_path / "marked", tmp_path / "replayed"
    r = run_inproc(*RECORD, "--operator", "success@5", "--n-episodes", "1", "--out", str(out))
    assert r.returncode == 0, r.stderr
    assert "the operator marked the episode success; the scene's success criterion says not successful" in r.stderr
    (info,) = episode_infos(out)
    assert info["operator_verdict"] == "success" and info["scene_success"] is False

    r = run_inproc("replay", str(out), "--mode", "actions", "--out", str(res))
    assert r.returncode == 0, r.stderr
    lines = r.stdout.splitlines()
    assert any(line.split() == ["divergence", "max", "0"] for line in lines), r.stdout
    why = [line.split(None, 1)[1] for line in lines if line.split()[:1] == ["why"]]
    assert why == [
        "ep 0: the recorded success came from the operator's verdict; the scene's criterion said not successful"
    ]
    summary = json.loads((res / "summary.json").read_text())
    assert summary["reproduced"] == 0 and summary["operator_verdicts"] == [0]


def test_a_verdict_the_scene_agrees_with_is_stored_without_a_word(project: Path, tmp_path: Path) -> None:
    out = tmp_path / "failed"
    r = run_inproc(*RECORD, "--operator", "failure@5", "--n-episodes", "1", "--out", str(out))
    assert r.returncode == 0, r.stderr
    assert "operator marked" not in r.stderr
    (info,) = episode_infos(out)
    assert info["operator_verdict"] == "failure" and info["scene_success"] is False
