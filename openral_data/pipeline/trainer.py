"""lerobot 0.6.1's own training, on a LeRobot v3 dataset this tool wrote, offline and resumable.

`lerobot-train` (`lerobot.scripts.lerobot_train.train`) needs the `accelerate` package (`lerobot[training]`),
which the default environment does not install; `train_policy` is its single-process loop without it, built
from lerobot's own parts: `TrainPipelineConfig` (the config `lerobot-train` parses; stored as the checkpoint's
`train_config.json`), `make_dataset`, `make_policy`, `make_pre_post_processors`, the policy's optimizer and
scheduler preset, `EpisodeAwareSampler`, and `save_checkpoint` / `load_training_state` /
`update_last_checkpoint`, so the run folder is the one `lerobot-train` writes:
`<run>/checkpoints/<step>/{pretrained_model,training_state}` and `checkpoints/last` -> the newest complete one.
A run killed at any point resumes from `checkpoints/last` (weights, optimizer, scheduler, RNG state, step, and
the data order at the right epoch/offset, as `lerobot-train --resume` does).

Offline: only ACT is offered (`POLICY_TYPES`): its ResNet backbone is built without ImageNet weights
(`pretrained_backbone_weights=None`, nothing downloaded), and it needs at least one camera (or
`observation.environment_state`, which `record --policy` does not feed). Diffusion needs the `diffusers`
package (not installed); pi0/SmolVLA/GR00T need pretrained weights from the Hub.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

from openral_data.errors import CompatibilityError, ConfigError

POLICY_TYPES = ("act",)
PolicyType = Literal["act"]
LAST = "last"  # lerobot's LAST_CHECKPOINT_LINK


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


def last_checkpoint(run: Path) -> Path | None:
    """`run/checkpoints/last` when a complete checkpoint is there (lerobot links it after writing one)."""
    last = run / "checkpoints" / LAST
    return last if (last / "training_state").is_dir() and (last / "pretrained_model").is_dir() else None


def done_steps(run: Path) -> int:
    """The step of the run's last complete checkpoint (0: none)."""
    from lerobot.common.train_utils import load_training_step

    last = last_checkpoint(run)
    return 0 if last is None else int(load_training_step(last / "training_state"))


def pipeline_config(dataset: Path, run: Path, s: TrainSettings) -> Any:
    """lerobot's `TrainPipelineConfig` for `s` on the local dataset `dataset` (no Hub, no wandb)."""
    from lerobot.configs.default import DatasetConfig, WandBConfig
    from lerobot.configs.train import TrainPipelineConfig
    from lerobot.policies.act.configuration_act import ACTConfig

    policy = ACTConfig(
        device=s.device,
        pretrained_backbone_weights=None,
        push_to_hub=False,
        chunk_size=s.chunk_size,
        n_action_steps=s.n_action_steps,
        dim_model=s.dim_model,
        dim_feedforward=s.dim_feedforward,
        n_encoder_layers=s.n_encoder_layers,
        optimizer_lr=s.lr,
        optimizer_lr_backbone=s.lr,
    )
    cfg = TrainPipelineConfig(
        dataset=DatasetConfig(repo_id=f"local/{dataset.name}", root=str(dataset), video_backend="pyav"),
        policy=policy,
        output_dir=run,
        steps=s.steps,
        batch_size=s.batch_size,
        seed=s.seed,
        num_workers=0,
        save_freq=s.save_freq,
        log_freq=max(1, s.save_freq),
        wandb=WandBConfig(enable=False),
    )
    cfg.optimizer = policy.get_optimizer_preset()
    cfg.scheduler = policy.get_scheduler_preset()
    return cfg


def train_policy(dataset: Path, run: Path, s: TrainSettings, log: Callable[[str], None] | None = None) -> Path:
    """Train to `s.steps` in `run` (resuming from its last checkpoint); returns the final `pretrained_model`."""
    from lerobot.common.train_utils import load_training_state

    if s.policy not in POLICY_TYPES:
        raise ConfigError(f"train.policy: {s.policy!r}: offline training offers {', '.join(POLICY_TYPES)}")
    from lerobot.utils.random_utils import set_seed

    cfg = pipeline_config(dataset, run, s)
    set_seed(s.seed)  # the initial weights; a resumed run then takes the RNG state its checkpoint saved
    try:
        parts = _build(cfg)
    except ValueError as exc:  # lerobot's feature checks, e.g. ACT without a camera
        raise CompatibilityError(f"{dataset}: train.policy: {s.policy} cannot train on this dataset: {exc}") from None
    policy, optimizer, scheduler = parts["policy"], parts["optimizer"], parts["scheduler"]
    step = 0
    last = last_checkpoint(run)
    if last is not None:
        _load_weights(policy, last / "pretrained_model")
        step, optimizer, scheduler = load_training_state(last, optimizer, scheduler)
        if log:
            log(f"resuming from {last.resolve().name} (step {step})")
    policy.train()
    while step < s.steps:
        for batch in _loader(cfg, parts["dataset"], step):
            loss = _update(policy, parts["preprocessor"](batch), optimizer, scheduler, cfg)
            step += 1
            if step % s.save_freq == 0 or step == s.steps:
                _save(cfg, step, parts, optimizer, scheduler)
                if log:
                    log(f"step {step}/{s.steps}: loss {loss:.4f}")
            if step >= s.steps:
                break
    final = last_checkpoint(run)
    assert final is not None
    return final / "pretrained_model"


def _build(cfg: Any) -> dict[str, Any]:
    from lerobot.datasets.factory import make_dataset
    from lerobot.optim.factory import make_optimizer_and_scheduler
    from lerobot.policies.factory import make_policy, make_pre_post_processors

    logging.getLogger("lerobot").setLevel(logging.WARNING)
    dataset = make_dataset(cfg)
    policy = make_policy(cfg=cfg.policy, ds_meta=dataset.meta)
    pre, post = make_pre_post_processors(policy_cfg=cfg.policy, dataset_stats=dataset.meta.stats)
    optimizer, scheduler = make_optimizer_and_scheduler(cfg, policy)
    return {
        "dataset": dataset,
        "policy": policy,
        "preprocessor": pre,
        "postprocessor": post,
        "optimizer": optimizer,
        "scheduler": scheduler,
    }


def _loader(cfg: Any, dataset: Any, step: int) -> Any:
    """lerobot-train's data order (an `EpisodeAwareSampler` seeded by the run's seed), continued at `step`."""
    import torch
    from lerobot.datasets import EpisodeAwareSampler, compute_sampler_state

    sampler = EpisodeAwareSampler(
        dataset.meta.episodes["dataset_from_index"],
        dataset.meta.episodes["dataset_to_index"],
        episode_indices_to_use=dataset.episodes,
        drop_n_last_frames=getattr(cfg.policy, "drop_n_last_frames", 0),
        shuffle=True,
        seed=cfg.seed,
        absolute_to_relative_idx=dataset.absolute_to_relative_idx,
    )
    if step > 0:
        sampler.load_state_dict(compute_sampler_state(step, len(sampler), cfg.batch_size, 1))
    return torch.utils.data.DataLoader(dataset, batch_size=cfg.batch_size, sampler=sampler, num_workers=0)


def _update(policy: Any, batch: Any, optimizer: Any, scheduler: Any, cfg: Any) -> float:
    import torch

    loss, _ = policy.forward(batch)
    loss.backward()
    if cfg.optimizer.grad_clip_norm > 0:
        torch.nn.utils.clip_grad_norm_(policy.parameters(), cfg.optimizer.grad_clip_norm)
    optimizer.step()
    optimizer.zero_grad()
    if scheduler is not None:
        scheduler.step()
    return float(loss.item())


def _save(cfg: Any, step: int, parts: dict[str, Any], optimizer: Any, scheduler: Any) -> None:
    """lerobot's checkpoint of `step`; `last` is re-linked only once it is complete (a kill while writing leaves
    `last` at the previous one)."""
    from lerobot.common.train_utils import get_step_checkpoint_dir, save_checkpoint, update_last_checkpoint

    where = get_step_checkpoint_dir(cfg.output_dir, cfg.steps, step)
    save_checkpoint(
        where,
        step,
        cfg,
        parts["policy"],
        optimizer,
        scheduler,
        parts["preprocessor"],
        parts["postprocessor"],
        num_processes=1,
        batch_size=cfg.batch_size,
    )
    update_last_checkpoint(where)


def _load_weights(policy: Any, pretrained: Path) -> None:
    from safetensors.torch import load_model

    load_model(policy, str(pretrained / "model.safetensors"), strict=True)
