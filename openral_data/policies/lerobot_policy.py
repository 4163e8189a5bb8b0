"""`policy: lerobot`: a lerobot 0.6.1 ACT or diffusion policy from a LOCAL checkpoint directory, on CPU (torch).

The rSkill manifest names the checkpoint in `policy_extras.checkpoint` (a directory as `lerobot-train` writes
under `checkpoints/<step>/pretrained_model/` or `save_pretrained` makes: `config.json`, `model.safetensors`,
`policy_preprocessor.json` / `policy_postprocessor.json` with their normaliser state); a relative path is
relative to the manifest's folder. Optional `policy_extras.device` (default `cpu`; `cuda[:N]`, `mps` or `auto`, see
openral_data.policies.device; `record --device` replaces it).

Nothing is downloaded: the checkpoint is read with `local_files_only`, and the torchvision backbone weights a
config may name (`pretrained_backbone_weights`, ImageNet by default in ACT) are switched off before the model is
built, since the checkpoint's own weights replace them anyway.

The checkpoint must speak the rSkill's contract, or it is refused before anything runs: output `action` of
`action_contract.dim`, input `observation.state` of `state_contract.dim`, and its cameras
(`observation.images.<name>`) exactly the rSkill's `required_cameras`. Images must arrive at the size the
checkpoint was made for. ACT policies are chunk-aware (`predict_chunk`, `n_action_steps`); diffusion keeps its
observation history inside `step` and needs the `diffusers` package (`lerobot[diffusion]`), which the default
environment does not install: without it a diffusion checkpoint is refused in one line.

`record --policy PATH` / `replay --policy PATH` (no manifest) come through this same loader: `policies/checkpoint.py`
locates the folder, reads its contract and makes the rSkill it runs as (`as_rskill`).
"""

from __future__ import annotations

import contextlib
import importlib.util
import io
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from openral_data.errors import CompatibilityError, ConfigError, ContractViolation, install_hint
from openral_data.formats.jsonfile import read_json
from openral_data.paths import contained, regular_file
from openral_data.policies.checkpoint import (
    ACTION,
    CONFIG,
    ENVIRONMENT,
    IMAGE_PREFIX,
    MAX_CONFIG_BYTES,
    ROOT,
    STATE,
    WEIGHTS,
    read_config,
)
from openral_data.policies.checkpoint_limits import check_step
from openral_data.policies.device import resolve_device
from openral_data.schemas.rskill import RSkillManifest
from openral_data.types import Observation

PROCESSOR_FILES = ("policy_preprocessor.json", "policy_postprocessor.json")  # what make_pre_post_processors reads


def checkpoint_dir(rskill: RSkillManifest) -> Path:
    value = rskill.policy_extras.get("checkpoint")
    if not isinstance(value, str) or not value:
        raise ConfigError(
            f"rskill {rskill.id}: policy_extras.checkpoint: a local lerobot checkpoint directory is required"
        )
    path = Path(value).expanduser()
    if not (path / CONFIG).is_file() or not (path / WEIGHTS).is_file():
        raise ConfigError(
            f"rskill {rskill.id}: policy_extras.checkpoint: {path} is not a lerobot checkpoint directory "
            "(needs config.json and model.safetensors)"
        )
    root = containment_root(rskill, path)
    for name in (CONFIG, WEIGHTS):
        inside(root, path, name, str(path / name))
    read_config(path)  # bounded, regular files, a policy type we load: before lerobot reads anything of it
    check_processor_steps(path, root)
    return path


def containment_root(rskill: RSkillManifest, path: Path) -> Path:
    """The folder the checkpoint's files must stay inside: `path` itself, or the Hub cache's repo folder
    `record --policy REPO_ID` found it in (`policy_extras.checkpoint_root`; a snapshot's files link to
    `../../blobs/`), which must hold `path`."""
    value = rskill.policy_extras.get(ROOT)
    if value is None:
        return path
    root = Path(str(value))
    if not path.is_relative_to(root):
        raise ConfigError(f"rskill {rskill.id}: policy_extras.{ROOT}: {root} does not hold the checkpoint {path}")
    return root


def inside(root: Path, path: Path, name: str, source: str) -> Path:
    """`path / name` (`path` inside `root`), refused in one line unless it stays inside `root` after symlinks
    (an absolute `name` or one with `..` is refused as such)."""
    return contained(root, str(path.relative_to(root) / name), source)


def check_processor_steps(path: Path, root: Path | None = None) -> None:
    """Refuse a checkpoint whose saved pre/post-processor names a step lerobot did not register, or a file
    outside `root` (default `path`).

    A checkpoint is code: lerobot's `DataProcessorPipeline.from_pretrained` imports and calls any `module.Name`
    a step's `class` names (`subprocess.Popen` included). Only lerobot's registered steps (`ProcessorStepRegistry`,
    by `registry_name` or by their own `module.Name`) are let through, before anything of the checkpoint loads,
    and of those only the pure tensor ones (`checkpoint_limits.PURE_STEPS`: not a reward classifier or tokenizer,
    which load a model or remote code from a path the step names).
    The processor files (read bounded, regular files) and each step's `state_file` (lerobot opens
    `path / state_file`) must stay inside `root` after symlinks.
    """
    from lerobot.policies import factory  # noqa: F401 - importing it registers lerobot's processor steps
    from lerobot.processor.pipeline import ProcessorStepRegistry

    root = path if root is None else root
    names = ProcessorStepRegistry.list()
    classes = {f"{c.__module__}.{c.__name__}": n for n in names for c in [ProcessorStepRegistry.get(n)]}
    for name in PROCESSOR_FILES:
        file = inside(root, path, name, str(path / name))
        try:
            doc = read_json(file, MAX_CONFIG_BYTES)
        except FileNotFoundError:
            continue  # lerobot reports a missing one itself
        steps = doc.get("steps") if isinstance(doc, dict) else None
        if not isinstance(steps, list):
            raise ConfigError(f"{file}: steps: missing or not a list")
        for i, step in enumerate(steps):
            named = step.get("registry_name") if isinstance(step, dict) else None
            cls = step.get("class") if isinstance(step, dict) and named is None else None
            if not (named in names if named is not None else isinstance(cls, str) and cls in classes):
                shown = named if named is not None else cls
                raise ConfigError(f"{file}: steps[{i}]: {shown!r} is not a registered lerobot processor step")
            check_step(named if named is not None else classes[str(cls)], f"{file}: steps[{i}]")
            if "state_file" in step:
                check_state_file(root, path, step["state_file"], f"{file}: steps[{i}].state_file")


def check_state_file(root: Path, path: Path, state_file: object, source: str) -> None:
    """A step's `state_file`: a relative file name whose `path / state_file` stays inside `root` after symlinks
    and is a regular file (lerobot would open an absolute or `..` one anywhere)."""
    if not isinstance(state_file, str) or not state_file:
        raise ConfigError(f"{source}: {state_file!r} is not a file name", code="config.checkpoint")
    try:
        regular_file(inside(root, path, state_file, source))
    except FileNotFoundError:
        raise ConfigError(f"{source}: {state_file!r} is missing", code="config.checkpoint") from None


def load_config(path: Path, device: str) -> Any:
    """The checkpoint's policy config (its `type` checked by `read_config`), made safe to instantiate offline on
    `device`."""
    import lerobot.policies.act.configuration_act
    import lerobot.policies.diffusion.configuration_diffusion  # noqa: F401 - registers the config types
    from lerobot.configs.policies import PreTrainedConfig

    try:
        config = PreTrainedConfig.from_pretrained(str(path), local_files_only=True)
    except Exception as exc:  # noqa: BLE001 - draccus/json errors of a foreign file: report them in one line
        raise ConfigError(f"{path / 'config.json'}: not a lerobot policy config: {exc}") from None
    if config.type == "diffusion" and importlib.util.find_spec("diffusers") is None:
        raise ConfigError(
            f"{path / 'config.json'}: type: diffusion policies need the diffusers package, which this environment "
            "does not install (pip install 'lerobot[diffusion]==0.6.1')"
        )
    if hasattr(config, "pretrained_backbone_weights"):
        config.pretrained_backbone_weights = None  # never fetch ImageNet weights; the checkpoint holds its own
    config.device = device
    return config


def check_features(config: Any, rskill: RSkillManifest, path: Path) -> None:
    """Refuse a checkpoint whose input/output features do not match the rSkill's contract (one line)."""
    where = f"{path}: config.json"
    out = config.output_features.get(ACTION)
    if out is None or tuple(out.shape) != (rskill.action_contract.dim,):
        have = None if out is None else list(out.shape)
        raise CompatibilityError(
            f"{where}: output_features.action: shape {have} does not match rskill {rskill.id} "
            f"action_contract.dim {rskill.action_contract.dim}"
        )
    inputs = dict(config.input_features)
    state = inputs.pop(STATE, None)
    if state is None or tuple(state.shape) != (rskill.state_contract.dim,):
        have = None if state is None else list(state.shape)
        raise CompatibilityError(
            f"{where}: input_features.observation.state: shape {have} does not match rskill {rskill.id} "
            f"state_contract.dim {rskill.state_contract.dim}"
        )
    cameras = sorted(k[len(IMAGE_PREFIX) :] for k in inputs if k.startswith(IMAGE_PREFIX))
    if cameras != sorted(rskill.required_cameras):
        raise CompatibilityError(
            f"{where}: input_features: cameras {cameras} but rskill {rskill.id} required_cameras are "
            f"{sorted(rskill.required_cameras)}"
        )
    inputs.pop(ENVIRONMENT, None)  # object poses (a state-only policy): fed when the scene records them
    other = sorted(k for k in inputs if not k.startswith(IMAGE_PREFIX))
    if other:
        raise CompatibilityError(f"{where}: input_features: {other} are not part of rskill {rskill.id}'s contract")


def load_weights(policy_class: Any, path: Path, config: Any) -> Any:
    """`policy_class.from_pretrained` of `path`'s weights; weights safetensors cannot read (a cut file) or that
    do not fit `config` (a tensor of another size) are one line naming the file."""
    from safetensors import SafetensorError

    weights = path / WEIGHTS
    try:
        with contextlib.redirect_stdout(io.StringIO()):  # lerobot prints "Loading weights from local directory"
            return policy_class.from_pretrained(str(path), config=config, local_files_only=True)
    except SafetensorError as exc:
        raise ConfigError(f"{weights}: weights: not readable safetensors ({exc})", code="config.checkpoint") from None
    except OSError as exc:
        raise ConfigError(f"{weights}: weights: cannot be read ({exc})", code="config.checkpoint") from None
    except RuntimeError as exc:  # torch's load_state_dict: a size mismatch lists every tensor on its own line
        lines = [line.strip() for line in str(exc).splitlines() if line.strip()] or [type(exc).__name__]
        said = " ".join(lines[:2]) + (f" (and {len(lines) - 2} more)" if len(lines) > 2 else "")
        raise ConfigError(f"{weights}: weights: do not fit {CONFIG}: {said}", code="config.checkpoint") from None


class LerobotPolicy:
    """PolicyAdapter over a lerobot policy + its saved pre/post-processors (normalisation)."""

    def __init__(self, rskill: RSkillManifest) -> None:
        import torch
        from lerobot.policies.factory import get_policy_class, make_pre_post_processors

        path = checkpoint_dir(rskill)
        device = resolve_device(
            str(rskill.policy_extras.get("device", "cpu")), f"rskill {rskill.id}: policy_extras.device"
        )
        self.device = device  # what a recording notes as the device used
        config = load_config(path, device)
        check_features(config, rskill, path)
        self._torch = torch
        self.config = config
        self._dim = rskill.action_contract.dim
        self._images = {key: tuple(f.shape) for key, f in config.image_features.items()}
        env = config.input_features.get(ENVIRONMENT)
        self._environment = None if env is None else int(env.shape[0])
        self.policy = load_weights(get_policy_class(config.type), path, config)
        self.pre, self.post = make_pre_post_processors(
            config, pretrained_path=str(path), preprocessor_overrides={"device_processor": {"device": device}}
        )
        self.policy.eval()

    def reset(self, seed: int) -> None:
        self._torch.manual_seed(seed)
        self.policy.reset()

    def _batch(self, obs: Observation, instruction: str) -> dict[str, Any]:
        torch = self._torch
        batch: dict[str, Any] = {STATE: torch.from_numpy(np.asarray(obs.state, dtype=np.float32)).unsqueeze(0)}
        for key, (c, h, w) in self._images.items():
            name = key[len(IMAGE_PREFIX) :]
            img = obs.images.get(name)
            if img is None or img.shape != (h, w, c):
                have = None if img is None else list(img.shape)
                raise ContractViolation(
                    f"camera {name}: the checkpoint expects images of {[h, w, c]} (HWC), got {have}"
                )
            batch[key] = torch.from_numpy(np.ascontiguousarray(img)).permute(2, 0, 1).float().div(255.0).unsqueeze(0)
        if self._environment is not None:
            env = obs.environment_state
            if env is None or env.shape != (self._environment,):
                have = None if env is None else list(env.shape)
                raise ContractViolation(f"{ENVIRONMENT}: the checkpoint expects [{self._environment}], got {have}")
            batch[ENVIRONMENT] = torch.from_numpy(np.asarray(env, dtype=np.float32)).unsqueeze(0)
        batch["task"] = [instruction]
        return self.pre(batch)  # type: ignore[no-any-return]

    def step(self, observation: Observation, instruction: str) -> npt.NDArray[np.float32]:
        with self._torch.inference_mode():
            action = self.post(self.policy.select_action(self._batch(observation, instruction)))
        return np.asarray(action.reshape(-1, self._dim)[0].cpu().numpy(), dtype=np.float32)

    def close(self) -> None:
        pass


class LerobotChunkPolicy(LerobotPolicy):
    """ACT without temporal ensembling: one query predicts `chunk_size` actions, `n_action_steps` are executed."""

    def __init__(self, rskill: RSkillManifest) -> None:
        super().__init__(rskill)
        self.n_action_steps = int(self.config.n_action_steps)

    def predict_chunk(self, observation: Observation, instruction: str) -> npt.NDArray[np.float32]:
        with self._torch.inference_mode():
            chunk = self.post(self.policy.predict_action_chunk(self._batch(observation, instruction)))
        return np.asarray(chunk.reshape(-1, self._dim).cpu().numpy(), dtype=np.float32)


def make_lerobot_policy(rskill: RSkillManifest) -> LerobotPolicy:
    if importlib.util.find_spec("lerobot") is None:  # the core install has no lerobot (nor torch)
        raise ConfigError(
            f"rskill {rskill.id}: policy: lerobot policies need the 'lerobot' extra: {install_hint('lerobot')}"
        )
    path = checkpoint_dir(rskill)
    config = load_config(path, "cpu")
    if config.type == "act" and getattr(config, "temporal_ensemble_coeff", None) is None:
        return LerobotChunkPolicy(rskill)
    return LerobotPolicy(rskill)
