"""A lerobot checkpoint named by `--policy PATH` (no rSkill manifest): where it is, what it is called, and the
contract its own config states.

`PATH` is a folder `save_pretrained` wrote (`config.json`, `model.safetensors`, the processors' JSON), a training
run's `checkpoints/<step>/pretrained_model` (or the step folder, or the run folder: its `checkpoints/last`), or a
Hub repo id found ONLY in the local Hugging Face cache (`local_files_only`; nothing is downloaded). The
checkpoint is untrusted: its files must stay inside the folder given (the cache's repo folder for a repo id)
after symlinks and be regular files, `config.json` is read bounded and its `type` may only name a policy type
we load (`SUPPORTED`); the processors' files, their steps and each step's `state_file` are checked by
`lerobot_policy.check_processor_steps` (inside `root`, which `as_rskill` passes on as `policy_extras.checkpoint_root`).

The contract (`CheckpointContract`) is the config's `input_features` / `output_features`: the state and action sizes and
the cameras with their (C, H, W) shapes; `check_fits` compares it with what a scene or dataset has, before an
episode runs. `as_rskill` turns it into the rSkill the rest of a run speaks (a base rSkill's names and
representations, the scene's; the checkpoint's cameras), so the one lerobot loader serves both ways.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from openral_data.errors import CompatibilityError, ConfigError, UsageError
from openral_data.formats.jsonfile import read_json
from openral_data.formats.repo_id import looks_like_repo_id
from openral_data.paths import contained, regular_file
from openral_data.policies.base import PolicyAdapter
from openral_data.policies.checkpoint_limits import check_sizes
from openral_data.policies.device import with_device
from openral_data.schemas.rskill import Contract, RSkillManifest
from openral_data.types import CameraShape, Observation, ProducerSpec

SUPPORTED = ("act", "diffusion")
CONFIG, WEIGHTS = "config.json", "model.safetensors"
IMAGE_PREFIX = "observation.images."
STATE, ACTION = "observation.state", "action"
ENVIRONMENT = "observation.environment_state"
# where the checkpoint is below PATH: itself, a step folder's, a training run's newest
LAYOUTS = ("", "pretrained_model", "checkpoints/last/pretrained_model")
MAX_CONFIG_BYTES = 4 << 20  # a policy config is a few KB
ROOT = "checkpoint_root"  # the policy_extras entry naming the folder the files must stay inside (`as_rskill`)


@dataclass(frozen=True)
class CheckpointContract:
    """What a checkpoint's config says it takes and gives: sizes, cameras `name -> (C, H, W)`, fps if stored, and
    the size of the `observation.environment_state` it takes (0: none; a state-only policy's object poses)."""

    state_dim: int
    action_dim: int
    cameras: dict[str, tuple[int, int, int]]
    fps: int | None = None
    environment_dim: int = 0


@dataclass(frozen=True)
class PolicyCheckpoint:
    """A located checkpoint folder, its name (`policy:<name>` in an episode's operator), its contract and the
    folder its files must stay inside (`root`: the folder given, or the cache's repo folder for a repo id)."""

    path: Path
    name: str
    contract: CheckpointContract
    root: Path

    @property
    def config_file(self) -> Path:
        return self.path / CONFIG


def open_checkpoint(ref: str) -> PolicyCheckpoint:
    """The checkpoint `ref` (a folder or a cached repo id) names, its config read and checked (one line if not)."""
    folder, name, root = _locate(ref)
    return PolicyCheckpoint(folder, name, read_contract(folder), root)


def _locate(ref: str) -> tuple[Path, str, Path]:
    given = Path(ref).expanduser()
    if given.exists() or given.is_symlink():
        if not given.is_dir():
            raise UsageError(f"--policy {ref}: not a folder (a lerobot checkpoint folder or a Hub repo id)")
        root, base, name = given, Path(), None
    elif looks_like_repo_id(ref):
        root, base = _cached(ref)
        name = ref
    else:
        raise UsageError(f"--policy {ref}: no such folder (nor a Hub repo id)")
    for layout in LAYOUTS:
        config = contained(root, str(base / layout / CONFIG), f"--policy {ref}")
        if config.exists():
            contained(root, str(base / layout / WEIGHTS), f"--policy {ref}")
            return config.parent, name or _folder_name(config.parent), root
    looked = ", ".join(lay or "." for lay in LAYOUTS)
    raise ConfigError(f"{root / base}: {CONFIG}: missing; not a lerobot checkpoint folder (looked in {looked})")


def _cached(repo_id: str) -> tuple[Path, Path]:
    """The cache folder of `repo_id` (the containment root: a snapshot's files link to `../../blobs/`) and its
    snapshot below it, from the local Hugging Face cache only; never downloaded."""
    from huggingface_hub import snapshot_download
    from huggingface_hub.constants import HF_HUB_CACHE
    from huggingface_hub.errors import LocalEntryNotFoundError

    try:
        snapshot = Path(snapshot_download(repo_id, local_files_only=True))
    except LocalEntryNotFoundError:
        raise UsageError(
            f"--policy {repo_id}: not a folder, and not in the local Hugging Face cache ({HF_HUB_CACHE}); "
            f"download it first (hf download {repo_id})"
        ) from None
    repo = snapshot.parent.parent
    return repo, snapshot.relative_to(repo)


def _folder_name(folder: Path) -> str:
    """`run@step` for a training run's `checkpoints/<step>/pretrained_model`, else the folder's name."""
    path = folder.resolve()
    if path.name == "pretrained_model":
        path = path.parent
    return f"{path.parent.parent.name}@{path.name}" if path.parent.name == "checkpoints" else path.name


def read_config(folder: Path) -> dict[str, Any]:
    """`folder/config.json` read bounded (a regular file, at most `MAX_CONFIG_BYTES`), its `type` one we load, the
    values that size memory bounded (`checkpoint_limits.check_sizes`), and `folder/model.safetensors` a regular
    file; anything else is one line naming the file and field."""
    file = folder / CONFIG
    try:
        doc = read_json(file, MAX_CONFIG_BYTES)
    except FileNotFoundError:
        raise ConfigError(f"{file}: missing; not a lerobot checkpoint folder") from None
    if not isinstance(doc, dict):
        raise ConfigError(f"{file}: not a JSON object; not a lerobot policy config")
    kind = doc.get("type")
    if kind not in SUPPORTED:
        raise ConfigError(f"{file}: type: {kind!r} policies are not supported ({', '.join(SUPPORTED)})")
    check_sizes(doc, file)  # before lerobot builds anything of the size it states
    try:
        regular_file(folder / WEIGHTS)
    except FileNotFoundError:
        raise ConfigError(f"{folder / WEIGHTS}: missing; the checkpoint has no weights") from None
    return doc


def read_contract(folder: Path) -> CheckpointContract:
    """The contract `folder/config.json` states (`read_config`'s checks first)."""
    doc = read_config(folder)
    file = folder / CONFIG
    inputs, outputs = doc.get("input_features"), doc.get("output_features")
    if not isinstance(inputs, dict) or not isinstance(outputs, dict):
        raise ConfigError(f"{file}: input_features/output_features: missing or not mappings")
    action = _shape(outputs, ACTION, file, "output_features", 1)
    state = _shape(inputs, STATE, file, "input_features", 1)
    other = sorted(k for k in inputs if k not in (STATE, ENVIRONMENT) and not k.startswith(IMAGE_PREFIX))
    if other:
        raise ConfigError(f"{file}: input_features: {other} are not a state or a camera this tool records")
    environment = _shape(inputs, ENVIRONMENT, file, "input_features", 1)[0] if ENVIRONMENT in inputs else 0
    cameras: dict[str, tuple[int, int, int]] = {}
    for key in inputs:
        if key.startswith(IMAGE_PREFIX):
            c, h, w = _shape(inputs, key, file, "input_features", 3)
            cameras[key[len(IMAGE_PREFIX) :]] = (c, h, w)
    fps = doc.get("fps")
    return CheckpointContract(state[0], action[0], cameras, fps if type(fps) is int and fps > 0 else None, environment)


def _shape(features: dict[str, Any], key: str, file: Path, side: str, rank: int) -> tuple[int, ...]:
    feature = features.get(key)
    shape = feature.get("shape") if isinstance(feature, dict) else None
    if not isinstance(shape, list) or len(shape) != rank or not all(type(n) is int and n > 0 for n in shape):
        raise ConfigError(f"{file}: {side}.{key}.shape: {shape!r} is not {rank} positive whole number(s)")
    return tuple(shape)


def check_fits(
    checkpoint: PolicyCheckpoint,
    where: str,
    *,
    state_dim: int | None,
    action_dim: int | None,
    cameras: Mapping[str, CameraShape],
    fps: int | None = None,
    environment_dim: int | None = None,
) -> None:
    """Refuse, in one line naming both sides, a checkpoint whose contract is not what `where` (a scene, a dataset)
    produces and accepts: state and action sizes, every camera it takes at its (H, W), its fps if it stored one,
    the environment state it takes (`environment_dim`: what `where` has; None: not known here)."""
    c, file = checkpoint.contract, checkpoint.config_file
    if c.environment_dim and environment_dim is not None and c.environment_dim != environment_dim:
        raise CompatibilityError(
            f"{file}: input_features.{ENVIRONMENT}: shape [{c.environment_dim}] but {where} has "
            + (f"an environment state of {environment_dim}" if environment_dim else "no environment state")
        )
    if state_dim is not None and c.state_dim != state_dim:
        raise CompatibilityError(
            f"{file}: input_features.observation.state: shape [{c.state_dim}] but {where} has a state of {state_dim}"
        )
    if action_dim is not None and c.action_dim != action_dim:
        raise CompatibilityError(
            f"{file}: output_features.action: shape [{c.action_dim}] but {where} takes actions of {action_dim}"
        )
    for name, (_, h, w) in sorted(c.cameras.items()):
        have = cameras.get(name)
        if have is None:
            raise CompatibilityError(
                f"{file}: input_features.{IMAGE_PREFIX}{name}: camera {name!r} but {where} has {sorted(cameras)}"
            )
        if (have.height, have.width) != (h, w):
            raise CompatibilityError(
                f"{file}: input_features.{IMAGE_PREFIX}{name}.shape: {h}x{w} (HxW) but {where} records "
                f"{have.height}x{have.width}"
            )
    if c.fps is not None and fps is not None and c.fps != fps:
        raise CompatibilityError(f"{file}: fps: {c.fps} but {where} runs at {fps} fps")


def check_fits_scene(checkpoint: PolicyCheckpoint, spec: ProducerSpec, rskill: RSkillManifest, where: str) -> None:
    """`check_fits` against a built scene's spec (a size it leaves open, the mock's, is `rskill`'s)."""
    check_fits(
        checkpoint,
        where,
        state_dim=rskill.state_contract.dim if spec.state_dim is None else spec.state_dim,
        action_dim=rskill.action_contract.dim if spec.action_dim is None else spec.action_dim,
        cameras=spec.cameras,
        fps=spec.fps,
        environment_dim=len(spec.environment_state_names),
    )


def dataset_cameras(features: Mapping[str, Any]) -> dict[str, CameraShape]:
    """A dataset's cameras (info.json `features`) with their sizes, for `check_fits`: a camera feature's shape is
    (H, W, C), or (C, H, W) when its `names` start with `channels` (lerobot writes either); an unreadable one
    is left out (the check then names it as missing)."""
    from openral_data.formats.lerobot_v3.features import camera_keys  # not at import: `list` checks checkpoints

    out: dict[str, CameraShape] = {}
    for name, key in camera_keys(dict(features)).items():
        shape, names = features[key].get("shape"), features[key].get("names")
        if not isinstance(shape, list) or len(shape) != 3 or not all(type(n) is int for n in shape):
            continue
        h, w = shape[1:] if isinstance(names, list) and names[:1] == ["channels"] else shape[:2]
        out[name] = CameraShape(height=h, width=w)
    return out


def as_rskill(checkpoint: PolicyCheckpoint, base: RSkillManifest | None) -> RSkillManifest:
    """The rSkill a run speaks with this checkpoint, run by the `lerobot` adapter with the checkpoint's cameras:
    `base`'s contract (the names and representations the scene or recording uses; its sizes are checked by
    `check_fits`), or without one (a dataset judged offline) a generic contract of the checkpoint's sizes."""
    ident = re.sub(r"[^A-Za-z0-9_\-.]", "-", checkpoint.name) or "checkpoint"
    c = checkpoint.contract
    if base is None:
        base = RSkillManifest(
            id=ident,
            policy="lerobot",
            embodiment_tags=["lerobot"],
            state_contract=Contract(dim=c.state_dim, names=[f"state_{i}" for i in range(c.state_dim)]),
            action_contract=Contract(dim=c.action_dim, names=[f"action_{i}" for i in range(c.action_dim)]),
        )
    return base.model_copy(
        update={
            "id": ident,
            "description": f"lerobot checkpoint {checkpoint.path}",
            "policy": "lerobot",
            "required_cameras": sorted(c.cameras),
            "policy_extras": {"checkpoint": str(checkpoint.path), ROOT: str(checkpoint.root)},
        }
    )


class OperatedPolicy:
    """`policy` (a `PolicyAdapter`) whose episodes say who drove them: `episode_info()` is `{"operator":
    "policy:<name>"}` (an `AnnotatingPolicy`, so `record` stores it); the rest is `policy`'s own."""

    def __init__(self, policy: PolicyAdapter, checkpoint: PolicyCheckpoint) -> None:
        self.policy = policy
        self.operator = f"policy:{checkpoint.name}"
        self.device: str | None = getattr(policy, "device", None)  # what a recording notes as the device used

    def reset(self, seed: int) -> None:
        self.policy.reset(seed)

    def step(self, observation: Observation, instruction: str) -> npt.NDArray[np.float32]:
        return self.policy.step(observation, instruction)

    def episode_info(self) -> dict[str, Any]:
        return {"operator": self.operator}

    def close(self) -> None:
        self.policy.close()


def load_operated(
    make: Callable[[RSkillManifest], PolicyAdapter],
    rskill: RSkillManifest,
    *,
    device: str | None,
    checkpoint: PolicyCheckpoint | None,
) -> PolicyAdapter:
    """The policy `make` builds for `rskill` on `device` (`--device`; None: the rSkill's own), wrapped as an
    `OperatedPolicy` when a checkpoint drives (`--policy`): one way for a scene's recording and a HAL's."""
    policy = make(with_device(rskill, device))
    return policy if checkpoint is None else OperatedPolicy(policy, checkpoint)
