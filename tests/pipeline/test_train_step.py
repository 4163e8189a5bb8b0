"""The `train` pipeline step: lerobot's training on a dataset the pipeline recorded, killed mid-training and
resumed from lerobot's last checkpoint; the checkpoint then drives `replay --mode closed-loop` and `record
--policy`. The YAML's train block takes numbers and a policy type, never code or paths."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest
import yaml
from safetensors.numpy import load_file

from openral_data.errors import ConfigError
from openral_data.pipeline.schema import Step, load_pipeline
from openral_data.pipeline.state import config_hash
from openral_data.pipeline.train_step import dataset_digest
from openral_data.pipeline.trainer import threads_env
from tests.support.cli import run_cli
from tests.support.home import REPO
from tests.support.lerobot_written import loaded_episodes
from tests.support.scenes import write_yaml
from tests.support.timing import TIMED

pytestmark = TIMED

REC = {"scenes": ["mock_pick"], "rskills": ["random-mock"], "seeds": {"count": 2}, "max_steps": 12, "codec": "h264"}
TRAIN = {"dataset": "rec", "steps": 6, "batch_size": 2, "save_freq": 2, "chunk_size": 5, "dim_model": 32,
         "n_encoder_layers": 1, "threads": 1}  # fmt: skip
EVAL = {"policy": "policy", "scene": "mock_pick", "seeds": {"start": 100, "count": 2}, "max_steps": 6}


def _run_until_first_checkpoint_then_sigkill(spec: Path, workdir: Path, last: Path) -> None:
    """`pipeline run` until lerobot-train (its subprocess) has linked a checkpoint, then SIGKILL both."""
    cmd = [sys.executable, "-m", "openral_data.cli", "pipeline", "run", str(spec), "--workdir", str(workdir)]
    proc = subprocess.Popen(cmd, cwd=REPO, start_new_session=True, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    deadline = time.monotonic() + 600
    while not (last / "training_state" / "training_step.json").is_file() and proc.poll() is None:
        assert time.monotonic() < deadline, "no checkpoint within 600 s"
        time.sleep(0.05)
    os.killpg(proc.pid, signal.SIGKILL)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == -signal.SIGKILL, err.decode()[-2000:]


def _step(root: Path) -> int:
    return int(json.loads((root / "training_state" / "training_step.json").read_text())["step"])


@pytest.mark.slow
def test_train_step_killed_resumes_and_its_checkpoint_drives_replay_and_record(project: Path, tmp_path: Path) -> None:
    spec = write_yaml(tmp_path / "p.yaml", {"name": "t", "steps": [
        {"id": "rec", "record": REC}, {"id": "policy", "train": TRAIN}, {"id": "eval", "evaluate": EVAL},
        {"id": "metrics", "stats": {"inputs": ["eval"]}}]})  # fmt: skip
    workdir = tmp_path / "run"
    run = workdir / "policy" / ".mock_pick--random-mock.training" / "run"
    _run_until_first_checkpoint_then_sigkill(spec, workdir, run / "checkpoints" / "last")
    assert _step(run / "checkpoints" / "last") in (2, 4)  # what the rerun must resume from, short of 6
    assert not (workdir / "policy" / "mock_pick--random-mock").exists()

    res = run_cli("pipeline", "run", str(spec), "--workdir", str(workdir))
    assert res.returncode == 0, res.stderr
    item = workdir / "policy" / "mock_pick--random-mock"
    prov = json.loads((item / "provenance.json").read_text())
    dataset = workdir / "rec" / "mock_pick--random-mock"
    assert prov["resumed"] is True and prov["steps"] == 6 and prov["threads"] == 1
    assert "lerobot.scripts.lerobot_train" in prov["trainer"]
    assert prov["dataset_digest"] == dataset_digest(dataset) and prov["versions"]["lerobot"] == "0.6.1"
    assert prov["lerobot_train_config"]["policy"]["pretrained_backbone_weights"] is None  # nothing downloaded
    assert _step(run / "checkpoints" / "last") == 6
    # the checkpoint was trained on this dataset: its normaliser holds the dataset's own state statistics
    stats = json.loads((dataset / "meta" / "stats.json").read_text())["observation.state"]
    model = item / "pretrained_model"
    norm = load_file(str(next(model.glob("policy_preprocessor_step_*_normalizer_processor.safetensors"))))
    np.testing.assert_allclose(norm["observation.state.mean"], stats["mean"], rtol=1e-5)
    # ... and normalises an environment state (object poses) as the state: lerobot's ACT default leaves it raw
    (normalizer,) = [s for s in json.loads((model / "policy_preprocessor.json").read_text())["steps"]
                     if s["registry_name"] == "normalizer_processor"]  # fmt: skip
    assert normalizer["config"]["norm_map"]["ENV"] == normalizer["config"]["norm_map"]["STATE"] == "MEAN_STD"
    config = json.loads((model / "config.json").read_text())
    assert set(config["input_features"]) == {"observation.state", "observation.images.front",
                                             "observation.images.wrist"}  # fmt: skip

    # the checkpoint drives the rebuilt scene in closed loop
    rep = run_cli("replay", str(dataset), "--mode", "closed-loop", "--policy", str(model), "--out",
                  str(tmp_path / "cl"), "--json")  # fmt: skip
    assert rep.returncode == 0, rep.stderr
    summary = json.loads(rep.stdout)
    assert summary["rskill"] == f"policy:{model}" and len(summary["episode_list"]) == 2
    # ... and the evaluate step's recording (record --policy) on unseen seeds, one stats row with its interval
    rollouts = workdir / "eval" / "policy--mock_pick--random-mock"
    info = json.loads((rollouts / "meta" / "info.json").read_text())
    assert (info["total_episodes"], info["total_frames"]) == (2, 12)
    episodes = pq.read_table(next((rollouts / "meta" / "episodes").rglob("*.parquet"))).to_pylist()
    assert [e["openral.seed"] for e in episodes] == [100, 101]
    assert {json.loads(e["openral.episode_info"])["operator"] for e in episodes} == {"policy:mock_pick--random-mock"}
    (group,) = json.loads((workdir / "metrics" / "report" / "stats.json").read_text())["groups"]
    assert group["dataset"] == "policy--mock_pick--random-mock" and group["episodes"] == 2
    assert 0 <= group["ci95_low"] <= group["success_rate"] <= group["ci95_high"]


def test_filter_step_keeps_the_episodes_that_succeeded(project: Path, tmp_path: Path) -> None:
    # mock_pick's seed 0 succeeds at step 40, seed 1 at 55: with 50 steps only episode 0 succeeds; `drop` leaves
    # the camera out (a state-only policy's training set), and the kept dataset still loads in lerobot
    rec = {**REC, "max_steps": 50}
    camera = "observation.images.front"
    spec = write_yaml(tmp_path / "p.yaml", {"name": "t", "steps": [
        {"id": "rec", "record": rec},
        {"id": "kept", "filter": {"dataset": "rec", "unflagged": False, "drop": [camera]}}]})  # fmt: skip
    res = run_cli("pipeline", "run", str(spec), "--workdir", str(tmp_path / "run"))
    assert res.returncode == 0, res.stderr
    kept = tmp_path / "run" / "kept" / "mock_pick--random-mock"
    episodes = pq.read_table(next((kept / "meta" / "episodes").rglob("*.parquet"))).to_pylist()
    assert [(e["openral.seed"], e["length"]) for e in episodes] == [(0, 40)]
    recorded = json.loads((tmp_path / "run" / "rec" / "mock_pick--random-mock" / "meta" / "info.json").read_text())
    assert camera in recorded["features"]
    assert camera not in json.loads((kept / "meta" / "info.json").read_text())["features"]
    assert not (kept / "videos" / camera).exists() and not list(kept.parent.glob("*.kept"))
    (frames,) = loaded_episodes(kept)
    assert len(frames) == 40


@pytest.mark.parametrize(
    ("train", "message"),
    [
        ({**TRAIN, "policy": "diffusion"}, "train.policy"),
        ({**TRAIN, "steps": 0}, "train.steps"),
        ({**TRAIN, "output_dir": "/etc"}, "output_dir"),
        ({**TRAIN, "dataset": "nope"}, "'nope' is not an earlier step"),
        ({**TRAIN, "n_action_steps": 9}, "n_action_steps 9 exceeds chunk_size 5"),
    ],
)
def test_train_yaml_takes_numbers_not_code_or_paths(tmp_path: Path, train: dict[str, object], message: str) -> None:
    spec = write_yaml(tmp_path / "p.yaml", {"name": "t", "steps": [{"id": "rec", "record": REC},
                                                                 {"id": "policy", "train": train}]})  # fmt: skip
    with pytest.raises(ConfigError, match=message):
        load_pipeline(spec)


def test_train_threads_reach_torch_and_waiting_threads_sleep(monkeypatch: pytest.MonkeyPatch) -> None:
    # on a busy machine torch's OpenMP threads spin-waiting for a descheduled one cost a 64x64-camera ACT step
    # 5.1 CPU-s instead of 0.72 (benchmarks/README.md "Trainability"): lerobot-train's torch runs the step's
    # `threads`, its waiting threads sleeping; a step written before `threads` existed keeps its hash
    step = Step.model_validate({"id": "p", "train": {"dataset": "rec", "steps": 6, "threads": 1}})
    assert step.train is not None and step.train.threads == 1
    assert config_hash(Step.model_validate({"id": "p", "train": {"dataset": "rec", "steps": 6}})) == "05e63e21eb86cd06"
    monkeypatch.delenv("OMP_WAIT_POLICY", raising=False)
    monkeypatch.delenv("OMP_NUM_THREADS", raising=False)
    probe = "import os, torch; print(torch.get_num_threads(), os.environ['OMP_WAIT_POLICY'])"
    run = subprocess.run([sys.executable, "-c", probe], env={**os.environ, **threads_env(1)}, check=True,
                         capture_output=True, text=True)  # fmt: skip
    assert run.stdout.split() == ["1", "PASSIVE"]
    assert threads_env(None) == {"OMP_WAIT_POLICY": "PASSIVE"}  # torch's own count (one per core)
    monkeypatch.setenv("OMP_WAIT_POLICY", "ACTIVE")  # the user's choice wins
    assert threads_env(None) == {"OMP_WAIT_POLICY": "ACTIVE"}


def test_training_a_dataset_lerobot_refuses_is_one_line(project: Path, tmp_path: Path) -> None:
    # ACT needs a camera (or an environment state): a camera-less recording is refused in one line, exit 2
    scene = yaml.safe_load((REPO / "openral_data/builtin/scenes/sim/mock_pick.yaml").read_text())
    scene["scene"].update(id="blind", cameras=[])
    scene["task"]["scene_id"] = "blind"
    write_yaml(tmp_path / "blind.yaml", scene)
    rec = {**REC, "scenes": ["blind.yaml"], "rskills": ["zero-mock"]}
    spec = write_yaml(tmp_path / "p.yaml", {"name": "t", "steps": [
        {"id": "rec", "record": rec}, {"id": "policy", "train": TRAIN}]})  # fmt: skip
    res = run_cli("pipeline", "run", str(spec), "--workdir", str(tmp_path / "run"))
    assert res.returncode == 2
    errors = [line for line in res.stderr.splitlines() if not line.startswith(("rec", "policy/"))]
    assert len(errors) == 1 and "Traceback" not in res.stderr, res.stderr
    assert errors[0].startswith("error: pipeline step policy/blind--zero-mock: ")
    assert "act cannot train on this dataset: You must provide at least one image" in errors[0]
    assert not (tmp_path / "run" / "policy" / "blind--zero-mock").exists()
