"""ManiSkill trajectories (`.h5` with `traj_N` groups and the `.json` beside it), a file or a folder of them:
split by file; the starting mapping from the agent's qpos/qvel, the cameras' rgb, actions named by the control
mode, rewards and success, the env id as task (`offline_mapping.maniskill_mapping`)."""

from __future__ import annotations

from openral_data.convert.kinds.arrays import LayoutMapping
from openral_data.convert.kinds.hdf5 import HDF5Kind
from openral_data.formats.episodic import ArrayEpisode, ArraySource


class ManiSkillKind(HDF5Kind):
    name = "hdf5-maniskill"
    summary = "HDF5: ManiSkill trajectories (.h5 with traj_N groups + its .json), a file or a folder"
    layouts = ("maniskill",)
    usual_fps = (20, "ManiSkill3's default control frequency (sim_config.control_freq)")

    def layout_mapping(self, source: ArraySource, first: ArrayEpisode) -> LayoutMapping:
        from openral_data.convert.offline_mapping import maniskill_mapping

        return maniskill_mapping(source, first)
