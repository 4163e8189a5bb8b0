"""Make a lerobot 0.6.1 ACT checkpoint locally from a dataset we recorded: the features and normalisation stats
come from the dataset (as lerobot-train does), optionally a few real training steps, then `save_pretrained` of
the policy and its pre/post-processors. Nothing is downloaded (no pretrained backbone). And what lerobot's own
loaded ACT policy computes on recorded frames (`lerobot_actions`), the frames taken exactly from an MCAP bag's raw
images (`raw_images`), to compare a recording's actions with."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np


def _features(dataset: Path, drop: tuple[str, ...]) -> tuple[Any, dict[str, Any], dict[str, Any]]:
    """The dataset's metadata and its policy input / output features, as lerobot-train derives them."""
    from lerobot.configs.types import FeatureType
    from lerobot.datasets.lerobot_dataset import LeRobotDatasetMetadata
    from lerobot.utils.feature_utils import dataset_to_policy_features

    meta = LeRobotDatasetMetadata("local/replay", root=dataset)
    features = dataset_to_policy_features(meta.features)
    outputs = {k: f for k, f in features.items() if f.type is FeatureType.ACTION}
    inputs = {k: f for k, f in features.items() if k not in outputs and k not in drop}
    return meta, inputs, outputs


def make_act_checkpoint(
    dataset: Path,
    out: Path,
    *,
    train_steps: int = 0,
    chunk_size: int = 10,
    n_action_steps: int = 4,
    drop: tuple[str, ...] = (),
    **config: Any,
) -> Path:
    """`drop`: dataset features the policy does not take as input (e.g. a camera its rSkill does not require)."""
    import torch
    from lerobot.datasets.lerobot_dataset import LeRobotDataset
    from lerobot.policies.act.configuration_act import ACTConfig
    from lerobot.policies.act.modeling_act import ACTPolicy
    from lerobot.policies.factory import make_pre_post_processors

    torch.manual_seed(0)
    meta, inputs, outputs = _features(dataset, drop)
    cfg = ACTConfig(
        input_features=inputs,
        output_features=outputs,
        chunk_size=chunk_size,
        n_action_steps=n_action_steps,
        dim_model=64,
        n_heads=2,
        dim_feedforward=128,
        n_encoder_layers=1,
        n_decoder_layers=1,
        n_vae_encoder_layers=1,
        latent_dim=8,
        pretrained_backbone_weights=None,
        device="cpu",
        **config,
    )
    policy = ACTPolicy(cfg)
    pre, post = make_pre_post_processors(cfg, dataset_stats=meta.stats)
    if train_steps:
        ds = LeRobotDataset(
            "local/replay",
            root=dataset,
            video_backend="pyav",
            delta_timestamps={"action": [i / meta.fps for i in range(chunk_size)]},
        )
        loader = torch.utils.data.DataLoader(ds, batch_size=8, shuffle=True, num_workers=0)
        optimizer = torch.optim.AdamW(policy.parameters(), lr=1e-4)
        policy.train()
        batches = iter(loader)
        for _ in range(train_steps):
            batch = pre(next(batches))
            loss, _ = policy.forward(batch)
            optimizer.zero_grad()
            loss.backward()
            optimizer.step()
        policy.eval()
    policy.save_pretrained(out)
    pre.save_pretrained(out)
    post.save_pretrained(out)
    return out


def make_diffusion_checkpoint(dataset: Path, out: Path, *, drop: tuple[str, ...] = ()) -> Path:
    """A freshly initialised, deliberately tiny diffusion policy (2 denoising steps) on the dataset's features."""
    import torch
    from lerobot.policies.diffusion.configuration_diffusion import DiffusionConfig
    from lerobot.policies.diffusion.modeling_diffusion import DiffusionPolicy
    from lerobot.policies.factory import make_pre_post_processors

    torch.manual_seed(0)
    meta, inputs, outputs = _features(dataset, drop)
    cfg = DiffusionConfig(
        input_features=inputs,
        output_features=outputs,
        n_obs_steps=2,
        horizon=8,
        n_action_steps=4,
        crop_shape=None,
        down_dims=(32, 64),
        kernel_size=3,
        n_groups=8,
        diffusion_step_embed_dim=32,
        spatial_softmax_num_keypoints=8,
        num_inference_steps=2,
        pretrained_backbone_weights=None,
        device="cpu",
    )
    policy = DiffusionPolicy(cfg)
    pre, post = make_pre_post_processors(cfg, dataset_stats=meta.stats)
    policy.save_pretrained(out)
    pre.save_pretrained(out)
    post.save_pretrained(out)
    return out


def lerobot_actions(checkpoint: Path, states: np.ndarray, images: list[np.ndarray], task: str) -> np.ndarray:
    """What lerobot's own policy (from_pretrained + its saved processors, none of our code) does on these frames."""
    import torch
    from lerobot.policies.act.modeling_act import ACTPolicy
    from lerobot.policies.factory import make_pre_post_processors

    policy = ACTPolicy.from_pretrained(str(checkpoint))
    pre, post = make_pre_post_processors(policy.config, pretrained_path=str(checkpoint))
    policy.eval()
    policy.reset()
    out = []
    with torch.inference_mode():
        for state, image in zip(states, images, strict=True):
            batch = {
                "observation.state": torch.from_numpy(state).unsqueeze(0),
                "observation.images.front": torch.from_numpy(image).permute(2, 0, 1).float().div(255).unsqueeze(0),
                "task": [task],
            }
            out.append(post(policy.select_action(pre(batch))).reshape(-1).numpy())
    return np.stack(out)


def raw_images(bag: Path, camera: str) -> list[np.ndarray]:
    """The exact frames the policy saw: the MCAP bag's raw sensor_msgs/Image messages, read by rosbags."""
    from rosbags.highlevel import AnyReader

    with AnyReader([bag]) as reader:
        conns = [c for c in reader.connections if c.topic == f"/camera/{camera}/image_raw"]
        msgs: list[Any] = [reader.deserialize(raw, c.msgtype) for c, _, raw in reader.messages(connections=conns)]
    return [np.array(m.data, dtype=np.uint8).reshape(m.height, m.width, 3) for m in msgs]
