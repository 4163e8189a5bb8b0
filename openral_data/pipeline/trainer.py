"""lerobot 0.6.1's own trainer (`lerobot-train`) on a LeRobot v3 dataset this tool wrote, offline and resumable.

`train_policy` runs `python -m lerobot.scripts.lerobot_train` (the `lerobot-train` console script, with the same
interpreter) as a subprocess: the local dataset by `--dataset.root` (its `--dataset.repo_id` a `local/NAME`
label, nothing fetched), `--dataset.video_backend=pyav` (torchcodec is not installed), the policy type and
sizes, `--steps`, `--batch_size`, `--seed`, `--save_freq`, `--policy.device`, `--output_dir` under the run
folder, `--policy.push_to_hub=false`, `--wandb.enable=false`, and `HF_HUB_OFFLINE=1`. lerobot writes
`<run>/checkpoints/<step>/{pretrained_model,training_state}` and re-links `checkpoints/last` once a checkpoint is
complete; a run killed at any point (the subprocess SIGKILLed included) is continued with lerobot's own
`--resume=true --config_path=<run>/checkpoints/last/pretrained_model/train_config.json` (weights, optimizer,
scheduler, RNG state, step, data order), and a run killed before its first checkpoint starts over.

Offline, per policy type (`POLICY_TYPES`): ACT's ResNet-18 backbone is built without ImageNet weights
(`--policy.pretrained_backbone_weights=null`); ACT needs a camera or `observation.environment_state` (a
state-only ACT on object poses has no backbone at all). Diffusion needs the `diffusers` package (not installed);
pi0, pi0.5, SmolVLA, GR00T and X-VLA start from pretrained Hub weights; none of them is offered.

Threads (`threads_env`): torch's OpenMP threads busy-wait for each other between operations, and on a busy
machine a descheduled thread leaves the others spinning: a 64x64-camera ACT step (batch 32) cost 5.1 CPU-s of
update with torch's default two threads on the loaded 2-core machine against 0.72 with one (benchmarks/README.md
"Trainability"). `lerobot-train` therefore runs with `OMP_WAIT_POLICY=PASSIVE` (waiting threads sleep: 0.83 CPU-s
with two) unless the environment sets it, and `threads` sets `OMP_NUM_THREADS` / `MKL_NUM_THREADS`.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

from openral_data.errors import CompatibilityError, ConfigError

POLICY_TYPES = ("act",)
PolicyType = Literal["act"]
# lerobot's ACT normalises VISUAL, STATE and ACTION only (its `normalization_mapping` default): the
# `observation.environment_state` (type ENV: the object poses a state-only policy reads) reached the network raw,
# a cube's few centimetres of spread a small part of its ~0.5 m offset, next to a normalised robot state
NORMALIZATION = {"VISUAL": "MEAN_STD", "STATE": "MEAN_STD", "ENV": "MEAN_STD", "ACTION": "MEAN_STD"}
LAST = "last"  # lerobot's LAST_CHECKPOINT_LINK
LOG = "lerobot-train.log"  # lerobot's output, in the run folder's parent
MODULE = "lerobot.scripts.lerobot_train"
# the exception line lerobot's traceback ends with: `ValueError: You must provide at least one image ...`
_RAISED = re.compile(r"^(?:[\w.]+\.)?(\w+(?:Error|Exception)): (.*)$")


@dataclass(frozen=True)
class TrainSettings:
    """What a `train` step may set (nothing that chooses code: a policy type of `POLICY_TYPES`, sizes, numbers)."""

    policy: PolicyType = "act"
    steps: int = 1000
    batch_size: int = 8
    seed: int = 1000
    save_freq: int = 500
    device: str = "cpu"
    chunk_size: int = 20
    n_action_steps: int = 20
    dim_model: int = 256
    dim_feedforward: int = 1024
    n_encoder_layers: int = 2
    lr: float = 1e-4
    temporal_ensemble_coeff: float | None = None  # ACT's temporal ensembling (needs n_action_steps 1)


def last_checkpoint(run: Path) -> Path | None:
    """`run/checkpoints/last` when a complete checkpoint is there (lerobot links it after writing one)."""
    last = run / "checkpoints" / LAST
    return last if (last / "training_state").is_dir() and (last / "pretrained_model").is_dir() else None


def done_steps(run: Path) -> int:
    """The step of the run's last complete checkpoint (0: none)."""
    last = last_checkpoint(run)
    if last is None:
        return 0
    return int(json.loads((last / "training_state" / "training_step.json").read_text())["step"])


def fresh_args(dataset: Path, run: Path, s: TrainSettings) -> list[str]:
    """`lerobot-train`'s arguments for a new run of `s` on the local dataset `dataset` (no Hub, no wandb)."""
    return [
        f"--dataset.repo_id=local/{dataset.name}",
        f"--dataset.root={dataset}",
        "--dataset.video_backend=pyav",
        f"--policy.type={s.policy}",
        f"--policy.device={s.device}",
        "--policy.push_to_hub=false",
        "--policy.pretrained_backbone_weights=null",
        f"--policy.chunk_size={s.chunk_size}",
        f"--policy.n_action_steps={s.n_action_steps}",
        f"--policy.dim_model={s.dim_model}",
        f"--policy.dim_feedforward={s.dim_feedforward}",
        f"--policy.n_encoder_layers={s.n_encoder_layers}",
        f"--policy.optimizer_lr={s.lr}",
        f"--policy.optimizer_lr_backbone={s.lr}",
        f"--policy.temporal_ensemble_coeff={json.dumps(s.temporal_ensemble_coeff)}",
        f"--policy.normalization_mapping={json.dumps(NORMALIZATION)}",
        f"--output_dir={run}",
        f"--steps={s.steps}",
        f"--batch_size={s.batch_size}",
        f"--seed={s.seed}",
        f"--save_freq={s.save_freq}",
        f"--log_freq={max(1, min(s.save_freq, 100))}",
        "--num_workers=0",
        "--wandb.enable=false",
    ]


def resume_args(run: Path, steps: int) -> list[str]:
    """lerobot's own resume of `run` from its last checkpoint, trained on to `steps`."""
    config = run / "checkpoints" / LAST / "pretrained_model" / "train_config.json"
    return ["--resume=true", f"--config_path={config}", f"--output_dir={run}", f"--steps={steps}"]


def train_policy(dataset: Path, run: Path, s: TrainSettings, threads: int | None = None) -> tuple[Path, bool]:
    """`lerobot-train` to `s.steps` in `run`, resuming from its last checkpoint, with `threads` torch threads
    (None: torch's default, one per core); (the final `pretrained_model`, whether it resumed). A failure is one
    line naming the dataset and lerobot's own reason. `threads` is not a setting of the run (a resumed run may
    use another count: the same training)."""
    if s.policy not in POLICY_TYPES:
        raise ConfigError(f"train.policy: {s.policy!r}: offline training offers {', '.join(POLICY_TYPES)}")
    resumed = last_checkpoint(run) is not None
    if resumed and done_steps(run) >= s.steps:
        return run / "checkpoints" / LAST / "pretrained_model", True
    if not resumed and run.exists():
        shutil.rmtree(run)  # killed before its first checkpoint: nothing to resume, and lerobot refuses the folder
    args = resume_args(run, s.steps) if resumed else fresh_args(dataset, run, s)
    run.parent.mkdir(parents=True, exist_ok=True)
    log = run.parent / LOG
    with log.open("ab") as out:
        done = subprocess.run(
            [sys.executable, "-m", MODULE, *args],
            stdout=out,
            stderr=subprocess.STDOUT,
            env={**_offline(), **threads_env(threads)},
            check=False,
            preexec_fn=_die_with_parent if sys.platform == "linux" else None,
        )
    if done.returncode != 0:
        raise CompatibilityError(f"{dataset}: train.policy: {s.policy} cannot train on this dataset: {_reason(log)}")
    final = last_checkpoint(run)
    if final is None or done_steps(run) < s.steps:
        raise CompatibilityError(f"{dataset}: train: lerobot-train wrote no checkpoint of step {s.steps} ({log})")
    return final / "pretrained_model", resumed


def _die_with_parent() -> None:
    """In the child: SIGKILLed when the pipeline dies (PR_SET_PDEATHSIG), so no orphan keeps writing the run."""
    import ctypes
    import signal

    ctypes.CDLL(None).prctl(1, signal.SIGKILL)


def threads_env(threads: int | None) -> dict[str, str]:
    """The environment torch's CPU threads follow: waiting threads sleep (`OMP_WAIT_POLICY=PASSIVE`, unless the
    environment says otherwise) and, when `threads` is given, that many of them."""
    env = {"OMP_WAIT_POLICY": os.environ.get("OMP_WAIT_POLICY", "PASSIVE")}
    if threads is not None:
        env |= {"OMP_NUM_THREADS": str(threads), "MKL_NUM_THREADS": str(threads)}
    return env


def _offline() -> dict[str, str]:
    return {**os.environ, "HF_HUB_OFFLINE": "1", "WANDB_MODE": "disabled", "TOKENIZERS_PARALLELISM": "false"}


def _reason(log: Path) -> str:
    """The exception lerobot-train ended with (the last `XxxError: message` line of its log), else its exit."""
    with log.open("rb") as f:
        f.seek(max(0, log.stat().st_size - 20_000))
        lines = f.read().decode("utf-8", "replace").splitlines()
    for line in reversed(lines):
        found = _RAISED.match(line.strip())
        if found:
            return found.group(2)
    return f"lerobot-train failed (its output: {log})"
