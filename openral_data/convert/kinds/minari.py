"""Minari datasets (HDF5 format): the dataset folder, its `data` folder or its `main_data.hdf5`; one block (one
file); the starting mapping from the observation space's vectors and pictures, actions, rewards and
`infos/success` (`offline_mapping.minari_mapping`). The spaces are read with minari itself (the `minari` extra)."""

from __future__ import annotations

from pathlib import Path

from openral_data.convert.kinds.arrays import ArrayKind, LayoutMapping
from openral_data.formats.episodic import ArrayEpisode, ArraySource


class MinariKind(ArrayKind):
    name = "minari"
    summary = "Minari datasets (data/main_data.hdf5 + data/metadata.json), the dataset or its data folder"
    layouts = ("minari",)
    usual_fps = (10, "a placeholder: Minari stores no step rate")

    def open(self, path: Path) -> ArraySource | None:
        from openral_data.formats.minari import detect_minari  # h5py (and minari) only when a source is looked at

        return detect_minari(path)

    def open_block(self, src: Path, files: list[Path]) -> ArraySource | None:
        return self.open(src)

    def layout_mapping(self, source: ArraySource, first: ArrayEpisode) -> LayoutMapping:
        from openral_data.convert.offline_mapping import minari_mapping

        return minari_mapping(source, first)
