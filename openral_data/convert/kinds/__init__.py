"""The source registry: every kind of thing `convert SRC` and `info SRC` take, each declared once in its own
module (how it is detected, described, split for `--workers`, read, and its starting mapping: `SourceKind`),
registered here once and tried by everything in this one order:

1. `lerobot-v2`  LeRobot v2.0 / v2.1 dataset (`meta/info.json` says so), read in place
2. `lerobot-v3`  any other folder with `meta/info.json` (a LeRobot v3.0 dataset)
3. `ros1-bag`    a `.bag` file, or a folder whose bags are all `.bag` files
4. `mcap`        an `.mcap` of another profile than ros2 (Foxglove: protobuf, JSON, ROS 1), or a folder of them
5. `rosbag2`     a rosbag2 folder, a plain `.mcap`, or a folder holding bags of any kind
6. `minari`      a Minari dataset (its folder, its `data` folder or `main_data.hdf5`, with `metadata.json`)
7. `hdf5-robomimic`  an HDF5 file or folder of the robomimic family (robomimic, LIBERO, MimicGen / Isaac Lab)
8. `hdf5-aloha`  an HDF5 file or folder of ALOHA / ACT episodes
9. `hdf5-d4rl`   an HDF5 file or folder of D4RL's flat layout (root observations, actions, terminals/timeouts)
10. `hdf5-maniskill`  a ManiSkill trajectory `.h5` (its `.json` beside it) or a folder of them
11. `zarr`        a Zarr replay buffer (`.zarr` folder, `.zarr.zip`)
12. `rlds`        an RLDS / TFDS build folder

Datasets first (their folder may hold anything), then bags (found by their names alone, so no HDF5/Zarr library
is imported for them), then the array sources (Minari before the HDF5 kinds: its `data` folder holds an HDF5 file
of no HDF5 kind's layout; an HDF5 file's layout is decided once, `formats.hdf5`, robomimic's and ALOHA's first).
A kind's `open` returns None when the path is not of its kind and raises one line when it is but is broken (an
HDF5 file of no known layout stops the search there). What no kind takes is read as bags by `convert` (which then
says it is not a bag) and as a dataset by `info`.

Adding a source kind: one module here with a `SourceKind` subclass (an array source: an `ArrayKind`; an HDF5
family: an `HDF5Kind`), and one line in `_KINDS` below at its place in the order.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

from openral_data.convert.kinds.base import SourceKind
from openral_data.convert.kinds.hdf5_aloha import AlohaKind
from openral_data.convert.kinds.hdf5_d4rl import D4rlKind
from openral_data.convert.kinds.hdf5_maniskill import ManiSkillKind
from openral_data.convert.kinds.hdf5_robomimic import RobomimicKind
from openral_data.convert.kinds.lerobot import LeRobotV2Kind, LeRobotV3Kind
from openral_data.convert.kinds.mcap import McapKind
from openral_data.convert.kinds.minari import MinariKind
from openral_data.convert.kinds.rlds import RldsKind
from openral_data.convert.kinds.ros1 import Ros1Kind
from openral_data.convert.kinds.rosbag2 import Rosbag2Kind
from openral_data.convert.kinds.zarr_replay import ZarrKind

__all__ = ["BAGS", "DATASET", "KINDS", "Detected", "SourceKind", "detect", "kind_named"]

_KINDS: tuple[SourceKind[Any], ...] = (
    LeRobotV2Kind(),
    LeRobotV3Kind(),
    Ros1Kind(),
    McapKind(),
    Rosbag2Kind(),
    MinariKind(),
    RobomimicKind(),
    AlohaKind(),
    D4rlKind(),
    ManiSkillKind(),
    ZarrKind(),
    RldsKind(),
)
KINDS: dict[str, SourceKind[Any]] = {kind.name: kind for kind in _KINDS}  # in the order they are tried
BAGS = KINDS["rosbag2"]  # what `convert` reads a source no kind takes as
DATASET = KINDS["lerobot-v3"]  # ... and `info`


@dataclass(frozen=True)
class Detected:
    """A source and the kind that took it (`handle`: what the kind opened, e.g. an `ArraySource`)."""

    kind: SourceKind[Any]
    path: Path
    handle: Any


def detect(path: Path) -> Detected | None:
    """The first kind (in the order above) that takes `path`, or None."""
    for kind in KINDS.values():
        handle = kind.open(path)
        if handle is not None:
            return Detected(kind, path, handle)
    return None


def kind_named(name: str) -> SourceKind[Any]:
    return KINDS[name]
