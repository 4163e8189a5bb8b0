"""ManiSkill trajectories (`haosulab/ManiSkill:mani_skill/utils/wrappers/record.py`'s `RecordEpisode`, which
`replay_trajectory` and the motion-planning demos write through): a `.h5` file with one `traj_N` group a
trajectory and a `.json` of the same name beside it (`env_info`: `env_id`, `env_kwargs`, `max_episode_steps`;
`episodes`: `episode_id`, `control_mode`, `elapsed_steps`, `reset_kwargs`, ...).

In a trajectory of T steps `actions` (T, A), `terminated`, `truncated`, and when the task defines them `success`,
`fail`, `rewards` have T rows; `obs` (a dataset, or groups `agent/qpos`, `agent/qvel`, `extra/*`,
`sensor_data/<camera>/rgb|depth|seg`, `sensor_param/*`) and `env_states/*` have T + 1: the reset's row first.
Step t is obs row t with action t (the last obs row, the state after the last action, is left out). The JSON must
say the trajectory's length (`elapsed_steps`, as `actions` has) and one control mode for the file: an action's
meaning is its control mode's.
"""

from __future__ import annotations

import re
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import h5py

from openral_data.errors import DatasetError
from openral_data.formats.episodic import EpisodeMeta
from openral_data.formats.hdf5.files import member, natural_key, walk_datasets
from openral_data.formats.hdf5.windows import WindowEpisode, episode_columns
from openral_data.formats.jsonfile import read_json
from openral_data.paths import contained

TRAJ = re.compile(r"traj_(\d+)")
PLUS_ONE = {"obs": 0, "env_states": 0}  # T + 1 rows, the reset's first: steps are rows 0..T-1


def is_maniskill(f: h5py.File) -> bool:
    """Root groups `traj_N`, the first of them with `actions`."""
    trajs = sorted((k for k in f if TRAJ.fullmatch(k)), key=natural_key)
    first = f.get(trajs[0]) if trajs else None
    return isinstance(first, h5py.Group) and "actions" in first


def sidecar(path: Path) -> Path:
    return path.with_suffix(".json")


def _dict(value: Any, where: str, what: str) -> dict[str, Any]:
    if not isinstance(value, dict):
        raise DatasetError(f"{where}: not an object ({what})", code="dataset.source.invalid")
    return value


class ManiSkillFile:
    """One trajectory file and its JSON (the `ArraySource` of one file)."""

    layout = "maniskill"

    def __init__(self, path: Path, f: h5py.File) -> None:
        self.path = path
        self.f = f
        meta = contained(path.parent, sidecar(path).name, f"{path}: its .json")  # no symlink out of the folder
        try:
            doc = _dict(read_json(meta), str(meta), "ManiSkill's trajectory metadata")
        except FileNotFoundError:
            raise DatasetError(f"{meta}: missing (ManiSkill writes the trajectories' metadata beside the .h5)",
                               code="dataset.source.key") from None  # fmt: skip
        self.env_info = _dict(doc.get("env_info"), f"{meta}: env_info", "env_id, env_kwargs")
        env_id = self.env_info.get("env_id")
        if not isinstance(env_id, str) or not env_id:
            raise DatasetError(f"{meta}: env_info.env_id: not a name", code="dataset.source.invalid")
        self.env_id = env_id
        episodes = doc.get("episodes")
        if not isinstance(episodes, list):
            raise DatasetError(f"{meta}: episodes: not a list", code="dataset.source.invalid")
        self.episode_info: dict[int, dict[str, Any]] = {}
        for i, raw in enumerate(episodes):
            ep = _dict(raw, f"{meta}: episodes[{i}]", "an episode's info")
            eid = ep.get("episode_id")
            if not isinstance(eid, int) or isinstance(eid, bool):
                raise DatasetError(f"{meta}: episodes[{i}].episode_id: not an integer", code="dataset.source.invalid")
            self.episode_info[eid] = ep
        self.source_type = doc.get("source_type") if isinstance(doc.get("source_type"), str) else None

    @property
    def env_kwargs(self) -> dict[str, Any]:
        kwargs = self.env_info.get("env_kwargs")
        return kwargs if isinstance(kwargs, dict) else {}

    @property
    def fps(self) -> float | None:
        """`env_kwargs.sim_config.control_freq` when the recording set it (ManiSkill's default is not stored)."""
        sim = self.env_kwargs.get("sim_config")
        freq = sim.get("control_freq") if isinstance(sim, dict) else None
        return float(freq) if isinstance(freq, (int, float)) and not isinstance(freq, bool) and freq > 0 else None

    def _info(self, name: str, control: list[str]) -> dict[str, Any]:
        """The JSON's episode of `traj_N`; its control mode the file's (the first episode's)."""
        eid = int(name.removeprefix("traj_"))
        where = f"{sidecar(self.path)}: episodes"
        info = self.episode_info.get(eid)
        if info is None:
            raise DatasetError(f"{where}: no episode_id {eid} (the .h5 has {name})", code="dataset.source.key")
        mode = info.get("control_mode")
        if not isinstance(mode, str) or not mode:
            raise DatasetError(f"{where}[episode_id={eid}].control_mode: missing", code="dataset.source.key")
        if control and mode != control[0]:
            raise DatasetError(f"{where}[episode_id={eid}].control_mode: {mode}, the first episode's is {control[0]} "
                               "(one file, one action meaning)", code="dataset.source.invalid")  # fmt: skip
        control.append(mode)
        return info

    def episodes(self) -> Iterator[WindowEpisode]:
        control: list[str] = []
        for name in sorted((k for k in self.f if TRAJ.fullmatch(k)), key=natural_key):
            group = member(self.f, name, self.path)
            if not isinstance(group, h5py.Group):
                raise DatasetError(f"{self.path}: {name}: not a group", code="dataset.source.invalid")
            info = self._info(name, control)
            actions = member(group, "actions", self.path)
            length = int(actions.shape[0]) if isinstance(actions, h5py.Dataset) and actions.shape else -1
            if length < 0 and isinstance(actions, h5py.Group):  # per-agent actions: the first agent's rows
                first = next((ds for _k, ds in walk_datasets(actions, self.path, ())), None)
                length = int(first.shape[0]) if first is not None and first.shape else -1
            steps = info.get("elapsed_steps")
            if length < 0 or steps != length:
                raise DatasetError(f"{self.path}: {name}/actions: {max(length, 0)} rows, the JSON's elapsed_steps "
                                   f"is {steps}", code="dataset.source.shape")  # fmt: skip
            columns = episode_columns(walk_datasets(group, self.path, ()), length, plus_one=PLUS_ONE, encodings={})
            attrs = {"env_id": self.env_id, "control_mode": info["control_mode"], "source_type": self.source_type,
                     "robot_uids": self.env_kwargs.get("robot_uids"), "episode_seed": info.get("episode_seed"),
                     "success": info.get("success")}  # fmt: skip
            yield WindowEpisode(name, self.path, length, columns, EpisodeMeta(None, attrs))

    def close(self) -> None:
        self.f.close()
