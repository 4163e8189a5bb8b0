"""The robomimic family of HDF5 files (robomimic / robosuite `data/demo_N`, LIBERO, MimicGen / Isaac Lab
recorder), a file or a folder of them: split by file; the starting mapping from `obs/*`, `actions`, the env
name or language instruction, `rewards` and `dones` (`array_mapping.robomimic_mapping`)."""

from __future__ import annotations

from openral_data.convert.kinds.arrays import LayoutMapping
from openral_data.convert.kinds.hdf5 import HDF5Kind
from openral_data.formats.episodic import ArrayEpisode, ArraySource


class RobomimicKind(HDF5Kind):
    name = "hdf5-robomimic"
    summary = "HDF5: robomimic / robosuite, LIBERO, MimicGen / Isaac Lab (data/demo_N), a file or a folder"
    layouts = ("robomimic", "libero", "mimicgen")

    def layout_mapping(self, source: ArraySource, first: ArrayEpisode) -> LayoutMapping:
        from openral_data.convert.array_mapping import robomimic_mapping

        return robomimic_mapping(source, first)
