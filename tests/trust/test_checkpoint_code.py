"""Class 3 of #49, a checkpoint chooses no code and reads nothing outside: a processor step lerobot registered
but that loads a model or a tokenizer (`reward_classifier_processor` naming a folder outside the checkpoint,
`action_tokenizer_processor` with its remote-code default) is refused in one line before anything of the
checkpoint loads, and a config value that sizes memory (`chunk_size` of 10**9) is one line before the policy is
built, under a memory limit that the old code ran into."""

from __future__ import annotations

import json
import shutil
from pathlib import Path
from typing import Any

import pytest

from tests.policies.conftest import checkpoint, mock  # noqa: F401  (a mock recording and its ACT checkpoint)
from tests.support.bounded import run_bounded
from tests.support.inproc import run_inproc

SCENE = "scenes/sim/mock_replay.yaml"


def _record_args(home: Path, policy: Path, out: Path) -> list[str]:
    return ["record", "--scene", str(home / SCENE), "--policy", str(policy), "--n-episodes", "1",
            "--max-steps", "3", "--out", str(out), "--vcodec", "h264"]  # fmt: skip


def _with_step(checkpoint: Path, dest: Path, step: dict[str, Any]) -> tuple[Path, int]:  # noqa: F811
    """A copy of `checkpoint` whose preprocessor gains `step` last; (the preprocessor file, the step's index)."""
    shutil.copytree(checkpoint, dest)
    pre = dest / "policy_preprocessor.json"
    doc = json.loads(pre.read_text())
    doc["steps"].append(step)
    pre.write_text(json.dumps(doc))
    return pre, len(doc["steps"]) - 1


def _one_line(stderr: str, start: str, needle: str) -> None:
    lines = [ln for ln in stderr.splitlines() if ln.strip()]
    assert "Traceback" not in stderr, stderr[-2000:]
    assert len(lines) == 1 and lines[0].startswith(f"error: {start}") and needle in lines[0], stderr[-2000:]


@pytest.mark.parametrize(
    "step",
    [
        {"registry_name": "reward_classifier_processor", "config": {"pretrained_path": "OUTSIDE", "device": "cpu"}},
        {
            "class": "lerobot.processor.hil_processor.RewardClassifierProcessorStep",
            "config": {"pretrained_path": "OUTSIDE"},
        },
        {"registry_name": "action_tokenizer_processor", "config": {"tokenizer_name": "OUTSIDE"}},
    ],
    ids=["reward-classifier", "reward-classifier-by-class", "action-tokenizer"],
)
def test_a_registered_step_that_loads_a_model_is_refused(
    step: dict[str, Any],
    mock: tuple[Path, Path],  # noqa: F811
    checkpoint: Path,  # noqa: F811
    tmp_path: Path,
) -> None:
    outside = tmp_path / "outside"
    outside.mkdir()
    (outside / "config.json").write_text(json.dumps({"type": "reward_classifier", "num_classes": 2}))
    config = {k: (str(outside) if v == "OUTSIDE" else v) for k, v in step["config"].items()}
    pre, index = _with_step(checkpoint, tmp_path / "ckpt", {**step, "config": config})
    out = tmp_path / "rec"
    done = run_inproc(*_record_args(mock[1], tmp_path / "ckpt", out))
    assert done.returncode == 2, done.stderr[-2000:]
    _one_line(done.stderr, f"{pre}: steps[{index}]: ", "does not load (it may load a model, a tokenizer or code")
    assert not out.exists()


@pytest.mark.parametrize(("key", "value"), [("chunk_size", 10**9), ("dim_model", 10**8), ("n_obs_steps", 10**7)])
def test_a_config_that_sizes_memory_is_bounded_before_the_policy_is_built(
    key: str,
    value: int,
    mock: tuple[Path, Path],  # noqa: F811
    checkpoint: Path,  # noqa: F811
    tmp_path: Path,
) -> None:
    ckpt = Path(shutil.copytree(checkpoint, tmp_path / "ckpt"))
    doc = json.loads((ckpt / "config.json").read_text())
    doc[key] = value
    (ckpt / "config.json").write_text(json.dumps(doc))
    out = tmp_path / "rec"
    run = run_bounded(*_record_args(mock[1], ckpt, out), timeout=120)
    assert not run.timed_out and run.returncode == 2, (run.returncode, run.stderr[-2000:])
    _one_line(run.stderr, f"{ckpt / 'config.json'}: {key}: ", "is not a whole number from 0 to")
    assert not out.exists()
