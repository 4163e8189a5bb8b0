"""The mapping of an array source (HDF5, Zarr, RLDS): the same `Mapping` as bags, with array keys (slash paths
relative to an episode, `obs/agentview_image`) where bags have topics, and the starting mapping `convert` uses
without `--mapping` (`robomimic_mapping`, `aloha_mapping`, `zarr_mapping`, `rlds_mapping`, each its source
kind's in `convert.kinds`): what a known layout holds, each guess said (`Guess`), printed by
`convert SRC --print-mapping` (`mapping_yaml`).

For array sources a role's `topic` is an array key and its `field` is not used; `task_topic: episode:language`
takes the episode's own language instruction (LIBERO's `problem_info`); `reward` takes a numeric per-step array;
`success` a per-step array whose non-zero values mean success (a `success` array, sparse `rewards`; robomimic's
`dones` is not one: it may mark every demo's end). Steps are
frames: `align` and `episodes` do not apply (episodes are the source's).
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Any

import yaml

from openral_data.errors import ConfigError, DatasetError
from openral_data.formats.episodic import ArrayEpisode, ArraySource, ArraySpec
from openral_data.schemas.base import validate
from openral_data.schemas.mapping import Mapping, Vector

LANGUAGE = "episode:language"  # task_topic: the episode's own language instruction
ALOHA_FPS = 50  # ACT / ALOHA record at 50 Hz (DT = 0.02 in their sim and real recorders); not in their files
ALOHA_JOINTS = [
    f"{side}_{j}"
    for side in ("left", "right")
    for j in ("waist", "shoulder", "elbow", "forearm_roll", "wrist_angle", "wrist_rotate", "gripper")
]


@dataclass(frozen=True)
class Guess:
    key: str  # the mapping's top-level key the guess is about
    why: str


def is_picture(spec: ArraySpec) -> bool:
    return spec.dtype == "uint8" and len(spec.shape) == 3 and spec.shape[-1] == 3


def is_vector(spec: ArraySpec) -> bool:
    return spec.encoding == "raw" and spec.dtype != "bytes" and len(spec.shape) <= 1


def camera_name(key: str) -> str:
    base = key.rsplit("/", 1)[-1]
    base = re.sub(r"_(image|rgb|img)$", "", base)
    return re.sub(r"[^A-Za-z0-9_]", "_", base) or "camera"


def _names(key: str, spec: ArraySpec) -> list[str]:
    width = spec.shape[0] if spec.shape else 1
    base = key.rsplit("/", 1)[-1]
    return [base] if not spec.shape else [f"{base}_{i}" for i in range(width)]


def part_of(key: str, spec: ArraySpec) -> dict[str, Any]:
    return {"topic": key, "names": _names(key, spec)}


def vector_of(parts: list[dict[str, Any]]) -> dict[str, Any]:
    return parts[0] if len(parts) == 1 else {"parts": parts}


def with_fps_guess(data: dict[str, Any], guesses: list[Guess], usual: int, why: str) -> None:
    """For printing only: a source without a step rate gets its layout's `usual` one, marked as a guess (a
    conversion never guesses the rate)."""
    if data.get("fps") is None:
        data["fps"] = usual
        guesses.insert(0, Guess("fps", f"{why}; the source does not say: check it"))


def specs_by_key(first: ArrayEpisode) -> dict[str, ArraySpec]:
    return {s.key: s for s in first.specs()}


def aloha_mapping(source: ArraySource, first: ArrayEpisode) -> tuple[dict[str, Any], list[Guess]]:
    specs = specs_by_key(first)
    state = specs.get("observations/qpos")
    action = specs.get("action")
    if state is None or action is None:
        raise DatasetError(f"{source.path}: observations/qpos or action: missing", code="dataset.source.key")
    named = state.shape == (14,) and action.shape == (14,)
    guesses = [Guess("task", "the folder's name; ALOHA files hold no task text")]
    if named:
        guesses.append(Guess("state", "ALOHA's 14 joints (left arm then right arm, 6 joints + gripper each)"))
    cams = {camera_name(k): k for k, s in specs.items() if k.startswith("observations/images/") and is_picture(s)}
    out: dict[str, Any] = {
        "robot_type": "aloha",
        "task": source.path.stem if source.path.is_file() else source.path.name,
        "state": {"topic": "observations/qpos", "names": ALOHA_JOINTS if named else _names("qpos", state)},
        "action": {"topic": "action", "names": ALOHA_JOINTS if named else _names("action", action)},
        "cameras": cams,
    }
    return out, guesses


def robomimic_mapping(source: ArraySource, first: ArrayEpisode) -> tuple[dict[str, Any], list[Guess]]:
    specs = specs_by_key(first)
    guesses: list[Guess] = []
    obs = {k: s for k, s in specs.items() if k.startswith("obs/")}
    low = {k: s for k, s in obs.items() if is_vector(s) and s.dtype.startswith("float")}
    env = [part_of(k, s) for k, s in low.items() if k.rsplit("/", 1)[-1].startswith("object")]
    state = [part_of(k, s) for k, s in low.items() if not k.rsplit("/", 1)[-1].startswith("object")]
    if state:
        guesses.append(Guess("state", "every low-dim obs/* array but object*, concatenated in key order"))
    elif "states" in specs:
        state = [part_of("states", specs["states"])]
        guesses.append(Guess("state", "no low-dim obs: the simulator state (states)"))
    else:
        raise DatasetError(f"{source.path}: {first.name}: no obs/* vectors and no states to map as state",
                           code="dataset.source.key")  # fmt: skip
    if "actions" not in specs:
        raise DatasetError(f"{source.path}: {first.name}/actions: missing", code="dataset.source.key")
    cams = {camera_name(k): k for k, s in obs.items() if is_picture(s)}
    attrs = first.meta.attrs.get("env_args") or {}
    env_name = attrs.get("env_name") if isinstance(attrs, dict) else None
    env_name = env_name or first.meta.attrs.get("env")  # robosuite's own demo.hdf5 says only `env`
    kwargs = attrs.get("env_kwargs") if isinstance(attrs, dict) else None
    robots = kwargs.get("robots") if isinstance(kwargs, dict) else None
    robot = robots[0] if isinstance(robots, list) and robots else robots
    out: dict[str, Any] = {"robot_type": str(robot).lower() if isinstance(robot, str) else "unknown"}
    if first.meta.language:
        out["task_topic"] = LANGUAGE
    else:
        out["task"] = str(env_name) if isinstance(env_name, str) and env_name else source.layout
        guesses.append(Guess("task", "the env name (env_args.env_name or env; no language instruction in the file)"))
    out["state"] = vector_of(state)
    out["action"] = {"topic": "actions", "names": _names("actions", specs["actions"])}
    if env:
        out["environment_state"] = vector_of(env)
        guesses.append(Guess("environment_state", "the obs/object* arrays (object poses and relations)"))
    out["cameras"] = cams
    if cams:
        origin, why = _robomimic_origin(source.layout)
        out["image_origin"] = origin
        guesses.append(Guess("image_origin", why))
    if "rewards" in specs and is_vector(specs["rewards"]) and not specs["rewards"].shape:
        out["reward"] = {"topic": "rewards"}
    success, why = _robomimic_success(specs, kwargs)
    if success is not None:
        out["success"] = {"topic": success}
    guesses.append(Guess("success", why))
    return out, guesses


def _robomimic_origin(layout: str) -> tuple[str, str]:
    """Whether a robomimic-family file stores its pictures bottom row first, and why. robosuite renders with
    OpenGL's origin (bottom row first) unless its IMAGE_CONVENTION macro says opencv. LIBERO's create_dataset script
    stores its env's observations as they come: bottom-up. robomimic's EnvRobosuite (its dataset_states_to_obs script,
    which MimicGen's generation also goes through) flips them (`di[k][::-1]`) before they are stored: upright."""
    if layout == "libero":
        return "bottom", (
            "LIBERO stores robosuite's renders as OpenGL reads them, bottom row first: flipped upright "
            "(image_origin: top keeps them as stored)"
        )
    return "top", (
        "robomimic's env wrapper (MimicGen's too) flips robosuite's renders upright before storing them: kept "
        "as stored (image_origin: bottom flips them)"
    )


def _robomimic_success(specs: dict[str, ArraySpec], kwargs: Any) -> tuple[str | None, str]:
    """The per-step array whose non-zero values mean success in a robomimic-family file, and why (None: unknown).
    `dones` never does: robomimic's dataset_states_to_obs sets it at success (done_mode 0), at the end of every demo
    (1) or both (2), and the file does not say which. `rewards` does when robosuite's reward is sparse
    (env_kwargs.reward_shaping: false: non-zero only on a step the task is done); shaped or unsaid, it does not."""
    if "success" in specs and is_vector(specs["success"]) and not specs["success"].shape:
        return "success", "the file's own per-step success array"
    shaping = kwargs.get("reward_shaping") if isinstance(kwargs, dict) else None
    if "rewards" in specs and is_vector(specs["rewards"]) and not specs["rewards"].shape and shaping is False:
        return "rewards", "rewards: sparse (env_kwargs.reward_shaping: false), non-zero only where the task is done"
    reason = "shaped" if shaping is True else "not said to be sparse (no env_kwargs.reward_shaping: false)"
    return None, (
        f"unknown: no success array; rewards {reason}; dones marks where a demo ends as often as success "
        "(robomimic's done_mode), so it is not used. Map `success: {topic: KEY}` if a key means success"
    )


def _store_name(source: ArraySource) -> str:
    name = source.path.name
    for suffix in (".zip", ".zarr"):
        name = name.removesuffix(suffix)
    return name or "task"


# UMI's action when its store has none (commit d095ba9590df789df5189eea5ee7e431689038a6):
# real-stanford/universal_manipulation_interface:diffusion_policy/common/sampler.py, `SequenceSampler.__init__`:
# without `action` in the replay buffer it concatenates, robot after robot, `robot<i>_eef_pos`,
# `robot<i>_eef_rot_axis_angle` and `robot<i>_gripper_width` of the same row; `sample_sequence` then takes the
# action chunk from the current row on (latency 0), and `UmiDataset.__getitem__`
# (real-stanford/universal_manipulation_interface:diffusion_policy/dataset/umi_dataset.py) reads 7 numbers a robot
# from it. So action[t] is the absolute end-effector pose (position, axis-angle rotation) and gripper width the
# demonstration holds at step t; UMI's relative pose and 6-d rotation are per-sample transforms of its training,
# not stored.
_UMI_ACTION = ("eef_pos", "eef_rot_axis_angle", "gripper_width")
_UMI_ROBOT = re.compile(r"data/robot(\d+)_eef_pos")
_UMI_ACTION_WHY = (
    "no data/action: UMI's training code (its SequenceSampler) builds it, per robot, from "
    "eef_pos + eef_rot_axis_angle + gripper_width of the same step (absolute pose, axis-angle)"
)


def _umi_action(specs: dict[str, ArraySpec]) -> list[dict[str, Any]]:
    """The parts of the action UMI derives for a store without `data/action` (see _UMI_ACTION); [] when the store
    has no `robot<i>_eef_pos`."""
    robots = sorted(int(m.group(1)) for k in specs if (m := _UMI_ROBOT.fullmatch(k)))
    keys = [f"data/robot{i}_{what}" for i in robots for what in _UMI_ACTION]
    return [part_of(k, specs[k]) for k in keys if k in specs and is_vector(specs[k])]


def zarr_mapping(source: ArraySource, first: ArrayEpisode) -> tuple[dict[str, Any], list[Guess]]:
    """diffusion policy / UMI replay buffers: `data/action`, else UMI's derived action (`_umi_action`);
    `data/state` or `data/agent_pos`, else every other float vector (UMI's robot0_*), as state; every HxWx3 uint8
    array a camera."""
    specs = specs_by_key(first)
    guesses = [Guess("task", "the store's name; replay buffers hold no task text")]
    if "data/action" in specs and is_vector(specs["data/action"]):
        action = part_of("data/action", specs["data/action"])
    elif derived := _umi_action(specs):
        action = vector_of(derived)
        guesses.append(Guess("action", _UMI_ACTION_WHY))
    else:
        raise DatasetError(f"{source.path}: data/action: missing (a replay buffer's action; nor UMI's "
                           "robot<i>_eef_pos to derive it from)", code="dataset.source.key")  # fmt: skip
    named_state = next((k for k in ("data/state", "data/agent_pos") if k in specs and is_vector(specs[k])), None)
    if named_state is not None:
        state = [part_of(named_state, specs[named_state])]
    else:
        state = [
            part_of(k, s) for k, s in specs.items() if k != "data/action" and is_vector(s) and s.dtype[:5] == "float"
        ]
        if not state:
            raise DatasetError(f"{source.path}: data/state: missing (no float vector to map as state)",
                               code="dataset.source.key")  # fmt: skip
        guesses.append(Guess("state", "every float vector under data/ but action, concatenated in key order"))
    out: dict[str, Any] = {
        "robot_type": "unknown",
        "task": _store_name(source),
        "state": vector_of(state),
        "action": action,
        "cameras": {camera_name(k): k for k, s in specs.items() if is_picture(s)},
    }
    return out, guesses


def rlds_mapping(source: ArraySource, first: ArrayEpisode) -> tuple[dict[str, Any], list[Guess]]:
    """RLDS / Open X-Embodiment: observation pictures as cameras, `steps/observation/state` (else every float
    observation vector) as state, `steps/action` (or its vector parts), language as task, reward, is_terminal."""
    specs = specs_by_key(first)
    obs = {k: s for k, s in specs.items() if k.startswith("steps/observation/")}
    floats = {k: s for k, s in obs.items() if is_vector(s) and s.dtype.startswith("float")}
    guesses: list[Guess] = []
    if "steps/observation/state" in floats:
        state = [part_of("steps/observation/state", floats["steps/observation/state"])]
    elif floats:
        state = [part_of(k, s) for k, s in floats.items()]
        guesses.append(Guess("state", "every float observation vector, concatenated in key order"))
    else:
        raise DatasetError(f"{source.path}: {first.name}: steps/observation: no float vector to map as state",
                           code="dataset.source.key")  # fmt: skip
    if "steps/action" in specs and is_vector(specs["steps/action"]):
        action = part_of("steps/action", specs["steps/action"])
    else:
        parts = [part_of(k, s) for k, s in specs.items() if k.startswith("steps/action/") and is_vector(s)]
        if not parts:
            raise DatasetError(f"{source.path}: {first.name}: steps/action: missing", code="dataset.source.key")
        action = vector_of(parts)
        guesses.append(Guess("action", "the vectors under steps/action/, concatenated in key order"))
    out: dict[str, Any] = {"robot_type": "unknown"}
    if first.meta.language:
        out["task_topic"] = LANGUAGE
    else:
        out["task"] = source.path.parent.name if source.path.name[:1].isdigit() else source.path.name
        guesses.append(Guess("task", "the dataset's name (no language_instruction in the episodes)"))
    out |= {"state": vector_of(state), "action": action}
    out["cameras"] = {camera_name(k): k for k, s in obs.items() if is_picture(s)}
    scalar = {k for k, s in specs.items() if is_vector(s) and not s.shape}
    if "steps/reward" in scalar:
        out["reward"] = {"topic": "steps/reward"}
    if "steps/is_terminal" in scalar:
        out["success"] = {"topic": "steps/is_terminal"}
        guesses.append(Guess("success", "is_terminal: the episode ended in a terminal state (check it means success)"))
    return out, guesses


def mapping_of(data: dict[str, Any], source: str) -> Mapping:
    """The starting mapping validated; a source that declares no step rate needs one (one line)."""
    if data.get("fps") is None:
        raise ConfigError(
            f"{source}: fps: the source declares no step rate; pass --fps N or a --mapping with fps "
            "(convert SRC --print-mapping prints a starting one)"
        )
    return validate(Mapping, data, f"{source}: built-in mapping")


def mapping_yaml(data: dict[str, Any], guesses: list[Guess], layout: str) -> str:
    """The starting mapping as YAML, each guessed key preceded by a `# guess:` comment."""
    why = {g.key: g.why for g in guesses}
    lines = [
        f"# starting mapping for a {layout} source (openral-data convert --print-mapping); edit and pass as --mapping"
    ]
    for key, value in data.items():
        if value is None or value == {}:
            continue
        if key in why:
            lines.append(f"# guess: {why[key]}")
        flow = None if isinstance(value, (dict, list)) else False  # leaf lists inline, the top level in blocks
        lines.append(yaml.safe_dump({key: value}, sort_keys=False, width=110, default_flow_style=flow).rstrip())
    lines += [f"# {g.key}: not mapped: {g.why}" for g in guesses if data.get(g.key) in (None, {})]
    return "\n".join(lines) + "\n"


def vector_keys(vector: Vector) -> list[str]:
    return [s.topic for s in vector.sources()]
