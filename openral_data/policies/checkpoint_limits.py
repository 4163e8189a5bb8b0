"""What an untrusted lerobot checkpoint may state before anything of it is built: the processor steps loaded
(`PURE_STEPS`: lerobot's registered steps known to be pure transforms of tensors, reading at most their own
`state_file`; a step that loads a model, a tokenizer or remote code is refused even though lerobot registered it)
and the config values that size memory (`check_sizes`: chunk sizes, horizons, observation steps, model widths
and depths, feature shapes), bounded so a `chunk_size` of 10**9 is one line instead of a process grown until it
is killed."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from openral_data.errors import ConfigError

# lerobot 0.6.1 registry names of steps that only move, rename, batch or (un)normalise tensors
PURE_STEPS = frozenset(
    {
        "normalizer_processor",
        "unnormalizer_processor",
        "device_processor",
        "rename_observations_processor",
        "to_batch_processor",
        "to_batch_processor_action",
        "to_batch_processor_observation",
        "to_batch_processor_complementary_data",
        "observation_processor",
        "numpy2torch_action_processor",
        "torch2numpy_action_processor",
    }
)
# config entries that size what the policy allocates, and their largest value (lerobot's defaults are far below)
SIZE_BOUNDS: dict[str, int] = {
    "chunk_size": 1000,
    "n_action_steps": 1000,
    "horizon": 1000,
    "n_obs_steps": 100,
    "dim_model": 8192,
    "dim_feedforward": 32768,
    "n_heads": 128,
    "n_encoder_layers": 64,
    "n_decoder_layers": 64,
    "n_vae_encoder_layers": 64,
    "latent_dim": 8192,
    "down_dims": 8192,
    "diffusion_step_embed_dim": 8192,
    "kernel_size": 64,
    "n_groups": 1024,
    "spatial_softmax_num_keypoints": 4096,
    "num_train_timesteps": 10000,
    "num_inference_steps": 10000,
}
MAX_FEATURE_DIM = 8192  # one axis of a feature's shape (a 8192-pixel-wide camera, a 8192-dim state)
MAX_FEATURE_VALUES = 64 << 20  # values of one feature (a 4096x4096 RGB picture is 50 M)


def check_sizes(doc: dict[str, Any], file: Path) -> None:
    """Each entry of `SIZE_BOUNDS` in the config `doc` (a whole number, or a list of them) at most its bound, and
    each input/output feature's shape bounded; anything else is one line naming the field."""
    for key, bound in SIZE_BOUNDS.items():
        value = doc.get(key)
        values = value if isinstance(value, list) else [value]
        for v in values:
            if v is None:
                continue
            if type(v) is not int or not 0 <= v <= bound:
                raise ConfigError(f"{file}: {key}: {_shown(value)} is not a whole number from 0 to {bound}",
                                  code="config.checkpoint")  # fmt: skip
    for side in ("input_features", "output_features"):
        features = doc.get(side)
        for name, feature in features.items() if isinstance(features, dict) else ():
            shape = feature.get("shape") if isinstance(feature, dict) else None
            if not isinstance(shape, list):
                continue  # the contract's own checks say what is wrong with it
            if not all(type(n) is int and 0 < n <= MAX_FEATURE_DIM for n in shape) or (
                math.prod(shape) > MAX_FEATURE_VALUES
            ):
                raise ConfigError(
                    f"{file}: {side}.{name}.shape: {_shown(shape)} is too large (at most {MAX_FEATURE_DIM} an axis, "
                    f"{MAX_FEATURE_VALUES} values)",
                    code="config.checkpoint",
                )


def check_step(named: str, source: str) -> None:
    """A registered step `named` is one of `PURE_STEPS`, or one line saying it loads more than tensors."""
    if named not in PURE_STEPS:
        raise ConfigError(
            f"{source}: {named!r} is a lerobot processor step this tool does not load (it may load a model, a "
            f"tokenizer or code; only pure tensor steps are: {', '.join(sorted(PURE_STEPS))})",
            code="config.checkpoint",
        )


def _shown(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 40 else text[:37] + "..."
