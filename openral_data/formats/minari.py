"""Minari datasets (Farama-Foundation/Minari, D4RL's maintained successor) in Minari's HDF5 format: a dataset
folder holding `data/metadata.json` (total episodes and steps, `data_format`, `jpeg_encoding`, the observation
and action spaces serialized by `minari.serialization`, `dataset_id`, `env_spec`, ...) and `data/main_data.hdf5`
(one `episode_N` group an episode, attrs `id`, `seed`, `total_steps`).

An episode of T steps has `actions`, `rewards`, `terminations`, `truncations` of T rows and `observations` and
`infos/*` of T + 1: the reset's first (what Minari's collector stores: reset's observation and info, then each
step's). Observations and actions follow their space: a Box is one dataset, a Dict a group of its keys, a Tuple a
group of `_index_i`. Step t is observation row t with action t, and info row t + 1: the info `step(action t)`
returned (so `infos/success` at step t says whether action t reached the goal). An image space Minari JPEG-encodes
(`jpeg_encoding`, its `is_image_space`) is decoded to HxWx3 pictures.

The spaces are read with minari's own deserializer (the `minari` extra), after their declared shapes are checked
bounded; the rows are read with h5py in bounded chunks (`formats.hdf5`). Nothing outside the dataset folder is
read: `data/` and its files are contained (no symlink out), the HDF5 file holds its own data. Minari's other
storage format (`arrow`) is refused in one line.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from openral_data.errors import ConfigError, DatasetError, install_hint
from openral_data.formats.episodic import Encoding, EpisodeMeta
from openral_data.formats.hdf5.files import MAX_STEP_BYTES, attr_scalar, member, natural_key, open_file, walk_datasets
from openral_data.formats.hdf5.windows import WindowEpisode, episode_columns
from openral_data.formats.jsonfile import parse_field, read_json
from openral_data.paths import contained

MAIN = "main_data.hdf5"
METADATA = "metadata.json"
PLUS_ONE = {"observations": 0, "infos": 1}  # T + 1 rows: steps are rows 0..T-1 of obs, 1..T of infos
MAX_EPISODES = 10_000_000


def data_folder(path: Path) -> Path | None:
    """The `data` folder of the Minari dataset `path` names (its folder, its `data` folder or its main_data.hdf5),
    None when `path` is none of these. A folder with main_data.hdf5 but no metadata.json is one line."""
    if path.is_file():
        folder = path.parent if path.name == MAIN else None
    elif (path / MAIN).is_file():
        folder = path
    elif (path / "data" / MAIN).is_file():
        folder = contained(path, "data", f"{path}: data")
    else:
        folder = None
    if folder is not None and not (folder / METADATA).exists():
        raise DatasetError(f"{folder / METADATA}: missing (a Minari dataset's metadata)", code="dataset.source.key")
    return folder


def _minari() -> Any:
    try:
        import minari.dataset.minari_storage as storage  # type: ignore[import-untyped]
        from minari import serialization
    except ImportError:
        raise ConfigError(f"Minari datasets need the 'minari' extra: {install_hint('minari')}") from None
    return serialization, storage


def _check_space(doc: Any, where: str) -> None:
    """A serialized space's declared shapes bounded (before minari builds its low/high arrays)."""
    if isinstance(doc, dict):
        shape = doc.get("shape")
        dims = shape if isinstance(shape, list) else []
        counts = all(isinstance(n, int) and not isinstance(n, bool) and n >= 0 for n in dims)
        if isinstance(shape, list) and (not counts or np.prod(shape, dtype=np.float64) * 8 > MAX_STEP_BYTES):
            raise DatasetError(f"{where}: shape {shape[:8]}: not a bounded shape", code="dataset.source.shape")
        subspaces = doc.get("subspaces")
        for sub in (
            subspaces.values() if isinstance(subspaces, dict) else subspaces if isinstance(subspaces, list) else []
        ):
            _check_space(sub, where)


def _space(metadata: dict[str, Any], name: str, where: str) -> Any:
    serialization, _ = _minari()
    raw = metadata.get(name)
    if not isinstance(raw, str):
        raise DatasetError(f"{where}.{name}: missing (a serialized space)", code="dataset.source.key")
    try:
        doc = parse_field(raw, f"{where}.{name}")
        _check_space(doc, f"{where}.{name}")
        return serialization.deserialize_space(doc)
    except DatasetError:
        raise
    except Exception as exc:  # noqa: BLE001 - minari's deserializer asserts, indexes and converts untrusted JSON
        raise DatasetError(f"{where}.{name}: not a space minari reads: {type(exc).__name__}: {str(exc)[:200]}",
                           code="dataset.source.invalid") from None  # fmt: skip


def _image_keys(space: Any, prefix: str, is_image: Any) -> list[str]:
    """The keys (slash paths) of the leaves of `space` that are image spaces."""
    from gymnasium import spaces

    if isinstance(space, spaces.Dict):
        return [k for key, sub in space.spaces.items() for k in _image_keys(sub, f"{prefix}/{key}", is_image)]
    if isinstance(space, spaces.Tuple):
        return [k for i, sub in enumerate(space.spaces) for k in _image_keys(sub, f"{prefix}/_index_{i}", is_image)]
    return [prefix] if is_image(space) else []


class MinariSource:
    """A Minari dataset (HDF5 format) as an `ArraySource`."""

    layout = "minari"
    fps: float | None = None  # Minari stores no step rate

    def __init__(self, path: Path, folder: Path) -> None:
        self.path = path
        self.folder = folder
        meta_path = contained(folder, METADATA, f"{folder}: {METADATA}")
        where = str(meta_path)
        metadata = read_json(meta_path)
        if not isinstance(metadata, dict):
            raise DatasetError(f"{where}: not an object", code="dataset.source.invalid")
        self.metadata = metadata
        fmt = metadata.get("data_format", "hdf5")
        if fmt != "hdf5":
            raise DatasetError(f"{where}: data_format: {str(fmt)[:40]!r}: only Minari's hdf5 format is read",
                               code="dataset.source.layout")  # fmt: skip
        _, storage = _minari()
        jpeg = bool(metadata.get("jpeg_encoding", True))
        self.observation_space = _space(metadata, "observation_space", where)
        self.action_space = _space(metadata, "action_space", where)
        images = _image_keys(self.observation_space, "observations", storage.is_image_space)
        images += _image_keys(self.action_space, "actions", storage.is_image_space)
        self.encodings: dict[str, Encoding] = dict.fromkeys(images, "jpeg") if jpeg else {}
        self.main = contained(folder, MAIN, f"{folder}: {MAIN}")
        self._file: h5py.File | None = None

    @property
    def dataset_id(self) -> str | None:
        value = self.metadata.get("dataset_id")
        return value if isinstance(value, str) and value else None

    def episodes(self) -> Iterator[WindowEpisode]:
        self._file = f = open_file(self.main)
        try:
            names = sorted((k for k in f if k.startswith("episode_")), key=natural_key)
            if len(names) > MAX_EPISODES:
                raise DatasetError(f"{self.main}: /: {len(names)} episodes (over {MAX_EPISODES})",
                                   code="dataset.source.shape")  # fmt: skip
            for name in names:
                yield self._episode(f, name)
        finally:
            self.close()

    def _episode(self, f: h5py.File, name: str) -> WindowEpisode:
        group = member(f, name, self.main)
        if not isinstance(group, h5py.Group):
            raise DatasetError(f"{self.main}: {name}: not a group", code="dataset.source.invalid")
        rewards = member(group, "rewards", self.main)
        length = int(rewards.shape[0]) if isinstance(rewards, h5py.Dataset) and len(rewards.shape) == 1 else -1
        declared = attr_scalar(group, "total_steps")
        if length < 0 or (isinstance(declared, int) and declared != length):
            raise DatasetError(f"{self.main}: {name}/rewards: {max(length, 0)} rows, total_steps says {declared}",
                               code="dataset.source.shape")  # fmt: skip
        columns = episode_columns(walk_datasets(group, self.main, ()), length, plus_one=PLUS_ONE,
                                  encodings=self.encodings)  # fmt: skip
        seed = attr_scalar(group, "seed")
        attrs = {"dataset_id": self.dataset_id, "seed": seed if isinstance(seed, int) else None}
        return WindowEpisode(name, self.main, length, columns, EpisodeMeta(None, attrs))

    def close(self) -> None:
        if self._file is not None:
            self._file.close()
            self._file = None


def detect_minari(path: Path) -> MinariSource | None:
    """`path` as a Minari dataset, or None when it is not one (a broken one is one line)."""
    folder = data_folder(path)
    return MinariSource(path, folder) if folder is not None else None
