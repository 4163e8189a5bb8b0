"""ALOHA / ACT episode files (`observations/qpos`, `action`, `observations/images/*`), a file or a folder of
them: split by file; the starting mapping names ALOHA's 14 joints and guesses 50 Hz when printed
(`array_mapping.aloha_mapping`)."""

from __future__ import annotations

from openral_data.convert.array_mapping import ALOHA_FPS
from openral_data.convert.kinds.arrays import LayoutMapping
from openral_data.convert.kinds.hdf5 import HDF5Kind
from openral_data.formats.episodic import ArrayEpisode, ArraySource


class AlohaKind(HDF5Kind):
    name = "hdf5-aloha"
    summary = "HDF5: ALOHA / ACT episode files (observations/qpos, action, observations/images), file or folder"
    layouts = ("aloha",)
    usual_fps = (ALOHA_FPS, "ACT / ALOHA record at 50 Hz")

    def layout_mapping(self, source: ArraySource, first: ArrayEpisode) -> LayoutMapping:
        from openral_data.convert.array_mapping import aloha_mapping

        return aloha_mapping(source, first)
