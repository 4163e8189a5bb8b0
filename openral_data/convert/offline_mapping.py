"""The starting mappings of the offline-RL and simulator-trajectory sources (`d4rl_mapping`, `minari_mapping`,
`maniskill_mapping`, each its source kind's in `convert.kinds`), in the terms of `convert.array_mapping`: what the
layout holds, each guess said.

Success is taken only from a signal that means it: a per-step `infos/success` (Minari's info after each step, and
D4RL's `infos/goal_achieved` / `infos/success` where a file has them), ManiSkill's per-step `success`. Never from
`terminals` / `terminations` (a locomotion terminal is a fall), `timeouts` / `truncations` (the clock) or dones.
"""

from __future__ import annotations

from typing import Any

from openral_data.convert.array_mapping import (
    Guess,
    camera_name,
    is_picture,
    is_vector,
    part_of,
    specs_by_key,
    vector_of,
)
from openral_data.errors import DatasetError
from openral_data.formats.episodic import ArrayEpisode, ArraySource, ArraySpec

LayoutMapping = tuple[dict[str, Any], list[Guess]]
NO_SUCCESS = "unknown: no per-step success signal ({what}); map `success: {{topic: KEY}}` if a key means it"


def _scalar(specs: dict[str, ArraySpec], key: str) -> bool:
    return key in specs and is_vector(specs[key]) and not specs[key].shape


def _numbers(spec: ArraySpec) -> bool:
    return is_vector(spec) and spec.dtype != "bool"


def _success(out: dict[str, Any], guesses: list[Guess], specs: dict[str, ArraySpec], keys: dict[str, str],
             what: str) -> None:  # fmt: skip
    """`success` from the first of `keys` (key -> why) the episode has as a per-step scalar, else unknown."""
    found = next((k for k in keys if _scalar(specs, k)), None)
    if found is not None:
        out["success"] = {"topic": found}
    guesses.append(Guess("success", keys[found] if found is not None else NO_SUCCESS.format(what=what)))


def d4rl_mapping(source: ArraySource, first: ArrayEpisode) -> LayoutMapping:
    """D4RL: `observations` as state, `actions`, `rewards`; success from `infos/success` or `infos/goal_achieved`."""
    specs = specs_by_key(first)
    for key in ("observations", "actions"):
        if key not in specs or not _numbers(specs[key]):
            why = first.meta.ignored.get(key, "not a vector of numbers a step")
            raise DatasetError(f"{source.path}: {key}: {why} (map it yourself with --mapping)",
                               code="dataset.source.shape")  # fmt: skip
    out: dict[str, Any] = {"robot_type": "unknown", "task": source.path.stem}
    guesses = [Guess("task", "the file's name; D4RL files hold no task text")]
    out["state"] = part_of("observations", specs["observations"])
    out["action"] = part_of("actions", specs["actions"])
    out["cameras"] = {camera_name(k): k for k, s in specs.items() if is_picture(s)}
    if _scalar(specs, "rewards"):
        out["reward"] = {"topic": "rewards"}
    keys = {k: f"{k}: the environment's own per-step goal signal" for k in ("infos/success", "infos/goal_achieved")}
    _success(out, guesses, specs, keys, "terminals mark a terminal state (a fall as often as a goal), timeouts the "
             "time limit: neither is success")  # fmt: skip
    return out, guesses


def _goal(key: str) -> bool:
    return "goal" in key.rsplit("/", 1)[-1]


def minari_mapping(source: ArraySource, first: ArrayEpisode) -> LayoutMapping:
    """Minari: the observation's number vectors as state (its goal vectors, gymnasium-robotics' achieved_goal /
    desired_goal, as environment_state), its pictures as cameras, `actions` (or a Dict action's vectors), rewards;
    success from `infos/success`."""
    specs = specs_by_key(first)
    obs = {k: s for k, s in specs.items() if k == "observations" or k.startswith("observations/")}
    vectors = {k: s for k, s in obs.items() if _numbers(s)}
    state = [part_of(k, s) for k, s in vectors.items() if not _goal(k)]
    env = [part_of(k, s) for k, s in vectors.items() if _goal(k)]
    guesses: list[Guess] = []
    if not state:
        raise DatasetError(f"{source.path}: {first.name}/observations: no number vector to map as state",
                           code="dataset.source.key")  # fmt: skip
    if len(state) > 1:
        guesses.append(Guess("state", "every number vector of the observation but its goals, in key order"))
    if "actions" in specs and _numbers(specs["actions"]):
        action = part_of("actions", specs["actions"])
    else:
        parts = [part_of(k, s) for k, s in specs.items() if k.startswith("actions/") and _numbers(s)]
        if not parts:
            raise DatasetError(f"{source.path}: {first.name}/actions: no number vector to map as action",
                               code="dataset.source.key")  # fmt: skip
        action = vector_of(parts)
        guesses.append(Guess("action", "the number vectors of the Dict / Tuple action, in key order"))
    dataset_id = first.meta.attrs.get("dataset_id")
    out: dict[str, Any] = {"robot_type": "unknown", "task": dataset_id or source.path.name}
    guesses.append(Guess("task", "the dataset id; Minari datasets hold no task text"))
    out |= {"state": vector_of(state), "action": action}
    if env:
        out["environment_state"] = vector_of(env)
        guesses.append(Guess("environment_state", "the observation's goal vectors (achieved_goal, desired_goal)"))
    out["cameras"] = {camera_name(k): k for k, s in obs.items() if is_picture(s)}
    if _scalar(specs, "rewards"):
        out["reward"] = {"topic": "rewards"}
    why = "infos/success: the info step(action) returned, the environment's own verdict"
    _success(out, guesses, specs, {"infos/success": why}, "terminations end an episode whether it failed or not")
    return out, guesses


def _robot(robots: Any) -> str:
    robot = robots[0] if isinstance(robots, list) and robots else robots
    return robot.lower() if isinstance(robot, str) and robot else "unknown"


def maniskill_mapping(source: ArraySource, first: ArrayEpisode) -> LayoutMapping:
    """ManiSkill: the agent's qpos and qvel (else a flat `obs` vector) as state, `obs/extra/*` vectors as
    environment_state, `obs/sensor_data/<camera>/rgb` as cameras, `actions` named by the control mode, rewards
    and the per-step `success`; the task is the env id."""
    specs = specs_by_key(first)
    attrs = first.meta.attrs
    state = [part_of(k, specs[k]) for k in ("obs/agent/qpos", "obs/agent/qvel") if k in specs and _numbers(specs[k])]
    if not state and "obs" in specs and _numbers(specs["obs"]):
        state = [part_of("obs", specs["obs"])]
    if not state:
        raise DatasetError(
            f"{source.path}: {first.name}/obs: no agent/qpos and no flat state vector (an obs_mode "
            "none file holds no observations: replay it with an obs_mode)",
            code="dataset.source.key",
        )
    if "actions" not in specs or not _numbers(specs["actions"]):
        raise DatasetError(f"{source.path}: {first.name}/actions: not a vector a step", code="dataset.source.shape")
    mode = str(attrs.get("control_mode") or "action")
    width = specs["actions"].shape[0] if specs["actions"].shape else 1
    out: dict[str, Any] = {"robot_type": _robot(attrs.get("robot_uids")), "task": attrs.get("env_id")}
    guesses = [Guess("task", "the env id (env_info.env_id); ManiSkill's trajectories hold no language")]
    out["state"] = vector_of(state)
    out["action"] = {"topic": "actions", "names": [f"{mode}_{i}" for i in range(width)]}
    env = [part_of(k, s) for k, s in specs.items() if k.startswith("obs/extra/") and _numbers(s) and s.dtype != "bool"]
    if env:
        out["environment_state"] = vector_of(env)
        guesses.append(Guess("environment_state", "every number vector under obs/extra (tcp pose, goal, object "
                             "poses: what the task adds), in key order"))  # fmt: skip
    out["cameras"] = {
        k.split("/")[2]: k for k, s in specs.items() if k.startswith("obs/sensor_data/") and k.endswith("/rgb")
        and is_picture(s)
    }  # fmt: skip
    if _scalar(specs, "rewards"):
        out["reward"] = {"topic": "rewards"}
    why = "success: the task's per-step info['success'] (RecordEpisode stores it when the task defines success)"
    _success(out, guesses, specs, {"success": why}, "terminated / truncated end an episode, they do not judge it")
    return out, guesses
