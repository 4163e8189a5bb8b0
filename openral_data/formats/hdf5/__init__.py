"""HDF5 episode sources (h5py) in the `formats.episodic` protocol: the robomimic family (robomimic / robosuite,
LIBERO, MimicGen / Isaac Lab recorder: `robomimic`), ALOHA / ACT episode files (`aloha`), D4RL's flat files
(`d4rl`) and ManiSkill trajectories (`maniskill`, with their `.json`).

`detect_hdf5(path)`: an HDF5 file, or a folder of them, as an `ArraySource` of the layout it holds (None when
`path` holds no HDF5 at all; one line when it is HDF5 of no known layout, or the files of a folder differ).
`files` of the source are its HDF5 files in order; `detect_hdf5(path, files=...)` opens a subset of them (a block
of `convert --workers`).
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import h5py

from openral_data.errors import DatasetError
from openral_data.formats.episodic import ArrayEpisode
from openral_data.formats.hdf5.aloha import AlohaFolder, is_aloha
from openral_data.formats.hdf5.d4rl import D4rlFile, is_d4rl
from openral_data.formats.hdf5.files import HDF5_SUFFIXES, is_hdf5, natural_key, open_file
from openral_data.formats.hdf5.maniskill import ManiSkillFile, is_maniskill
from openral_data.formats.hdf5.robomimic import RobomimicFile, robomimic_layout

__all__ = ["HDF5Source", "detect_hdf5", "hdf5_files"]


def hdf5_files(path: Path) -> list[Path]:
    """The HDF5 files of `path`: itself, or a folder's (not hidden, regular, HDF5 signature), in natural order."""
    if path.is_file():
        return [path] if is_hdf5(path) else []
    if not path.is_dir():
        return []
    found = [
        p
        for p in path.iterdir()
        if not p.name.startswith(".") and not p.is_symlink() and (p.suffix in HDF5_SUFFIXES or is_hdf5(p))
    ]
    return sorted(found, key=lambda p: natural_key(p.name))


Opened = RobomimicFile | AlohaFolder | D4rlFile | ManiSkillFile


def _file_layout(f: h5py.File) -> str | None:
    if layout := robomimic_layout(f):
        return layout
    return "aloha" if is_aloha(f) else "d4rl" if is_d4rl(f) else "maniskill" if is_maniskill(f) else None


def _layout(file: Path) -> str:
    f = open_file(file)
    try:
        layout = _file_layout(f)
        if layout is None:
            top = ", ".join(sorted(f.keys())[:20]) or "-"
            raise DatasetError(
                f"{file}: /: HDF5 of no known layout (top level: {top}; known: robomimic/LIBERO/MimicGen "
                "data/demo_N, ALOHA observations + action, D4RL observations + actions + terminals/timeouts, "
                "ManiSkill traj_N)",
                code="dataset.source.layout",
            )
        return layout
    finally:
        f.close()


class HDF5Source:
    """The episodes of one or more HDF5 files of one layout, file after file (files opened one at a time)."""

    def __init__(self, path: Path, files: list[Path], layout: str) -> None:
        self.path = path
        self.files = files
        self.layout = layout
        self.fps: float | None = None
        self._current: Opened | None = None
        if layout != "aloha":
            first = self._open(files[0])
            self.fps = first.fps
            first.close()

    def _open(self, file: Path) -> Opened:
        if self.layout == "aloha":
            return AlohaFolder(file, [file])
        f = open_file(file)
        try:
            layout = _file_layout(f)
            if layout != self.layout:
                raise DatasetError(
                    f"{file}: /: {layout or 'no known layout'}, the first file is {self.layout}",
                    code="dataset.source.layout",
                )
            return (
                D4rlFile(file, f)
                if layout == "d4rl"
                else ManiSkillFile(file, f)
                if layout == "maniskill"
                else RobomimicFile(file, f, layout)
            )
        except BaseException:
            f.close()
            raise

    def episodes(self) -> Iterator[ArrayEpisode]:
        for file in self.files:
            self._current = self._open(file)
            try:
                yield from self._current.episodes()
            finally:
                self.close()

    def close(self) -> None:
        if self._current is not None:
            self._current.close()
            self._current = None


def detect_hdf5(path: Path, files: list[Path] | None = None) -> HDF5Source | None:
    """`path` as an HDF5 source (`files`: only these of its files), or None when it holds no HDF5 file."""
    found = hdf5_files(path) if files is None else files
    if not found:
        return None
    return HDF5Source(path, found, _layout(found[0]))
