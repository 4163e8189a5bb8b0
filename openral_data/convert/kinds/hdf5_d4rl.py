"""D4RL's flat HDF5 (observations / actions / rewards / terminals / timeouts at the root, no episode groups), a
file or a folder of them: split by file; episodes cut at terminals / timeouts; the starting mapping from
observations, actions, rewards and a real success signal only (`offline_mapping.d4rl_mapping`)."""

from __future__ import annotations

from openral_data.convert.kinds.arrays import LayoutMapping
from openral_data.convert.kinds.hdf5 import HDF5Kind
from openral_data.formats.episodic import ArrayEpisode, ArraySource


class D4rlKind(HDF5Kind):
    name = "hdf5-d4rl"
    summary = "HDF5: D4RL flat files (observations, actions, rewards, terminals/timeouts at the root), file or folder"
    layouts = ("d4rl",)
    usual_fps = (20, "a placeholder: D4RL stores no step rate (its MuJoCo tasks step at 20 to 125 Hz)")

    def layout_mapping(self, source: ArraySource, first: ArrayEpisode) -> LayoutMapping:
        from openral_data.convert.offline_mapping import d4rl_mapping

        return d4rl_mapping(source, first)
