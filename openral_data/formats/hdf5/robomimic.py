"""The robomimic layout and the ones built on it: robomimic / robosuite (`data/demo_N/{obs/*, actions, states,
rewards, dones}`, `data.attrs["env_args"]` JSON), LIBERO (the same plus `data.attrs["problem_info"]` JSON with
`language_instruction`) and MimicGen / Isaac Lab's recorder (`data/demo_N/...` with an `initial_state` group).
A demo's ``ep_meta`` JSON attribute (RoboCasa, robomimic 0.5) gives its own language instruction (``lang``).

An episode is one `demo_N` group (in natural order: demo_2 before demo_10); its per-step arrays are every dataset
under it (nested groups as slash paths: `obs/agentview_image`, `states/articulation/robot/joint_position`) but
`next_obs/*` (the next step's obs, a copy shifted by one) and `initial_state/*` (one row, not per step). The step
rate is `env_args.env_kwargs.control_freq` when the file says it (robosuite and LIBERO do).
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import h5py
import numpy.typing as npt

from openral_data.errors import DatasetError
from openral_data.formats.episodic import ArraySpec, Encoding, EpisodeMeta
from openral_data.formats.hdf5.files import (
    attr_scalar,
    episode_specs,
    json_attr,
    member,
    natural_key,
    open_file,
    read_key,
    walk_datasets,
)

SKIPPED = ("next_obs", "initial_state", "datagen_info")  # groups that are not per-step arrays of this step
SPLITS = ("train", "valid")  # robomimic's train / validation filter keys (mask/<key>), in this order
MAX_DEMOS = 10_000_000


def robomimic_layout(f: h5py.File) -> str | None:
    """``robomimic``, ``libero`` or ``mimicgen`` for a file of this family, else None."""
    data = f.get("data")
    if not isinstance(data, h5py.Group):
        return None
    demos = [k for k in data if k.startswith("demo")]
    if not demos:
        return None
    if "problem_info" in data.attrs:
        return "libero"
    first = data.get(sorted(demos, key=natural_key)[0])
    if isinstance(first, h5py.Group) and ("initial_state" in first or "datagen_info" in first):
        return "mimicgen"
    return "robomimic"


class RobomimicEpisode:
    def __init__(self, file: Path, group: h5py.Group, meta: EpisodeMeta) -> None:
        self.file = file
        self.group = group
        self._meta = meta
        self.name = str(group.name).rsplit("/", 1)[-1]
        self.length = self._find_length()
        self._specs: dict[str, ArraySpec] | None = None

    def _find_length(self) -> int:
        actions = member(self.group, "actions", self.file)
        if not isinstance(actions, h5py.Dataset) or not actions.shape:
            raise DatasetError(
                f"{self.file}: {actions.name.lstrip('/')}: not an array of rows", code="dataset.source.shape"
            )
        length = int(actions.shape[0])
        declared = attr_scalar(self.group, "num_samples")
        if isinstance(declared, int) and declared != length:
            raise DatasetError(
                f"{self.file}: {self.group.name.lstrip('/')}: num_samples says {declared}, actions has {length} rows",
                code="dataset.source.shape",
            )
        return length

    @property
    def meta(self) -> EpisodeMeta:
        self._all()  # fills meta.ignored
        return self._meta

    def _all(self) -> dict[str, ArraySpec]:
        if self._specs is None:
            raw: Encoding = "raw"
            items = ((k, ds, raw) for k, ds in walk_datasets(self.group, self.file, SKIPPED))
            self._specs, self._meta.ignored = episode_specs(items, self.length, self.file)
        return self._specs

    def specs(self) -> list[ArraySpec]:
        return list(self._all().values())

    def read(self, key: str, start: int, stop: int) -> npt.NDArray[Any]:
        return read_key(self.group, self._all(), key, start, stop, self.file, self._meta.ignored)


class RobomimicFile:
    """One HDF5 file of the robomimic family (the `ArraySource` of one file)."""

    def __init__(self, path: Path, f: h5py.File, layout: str) -> None:
        self.path = path
        self.f = f
        self.layout = layout
        self.data: h5py.Group = member(f, "data", path)
        env_args = json_attr(self.data, "env_args", path)
        self.env_args: dict[str, Any] = env_args if isinstance(env_args, dict) else {}
        info = json_attr(self.data, "problem_info", path)
        self.problem_info: dict[str, Any] = info if isinstance(info, dict) else {}

    @property
    def fps(self) -> float | None:
        kwargs = self.env_args.get("env_kwargs")
        freq = kwargs.get("control_freq") if isinstance(kwargs, dict) else None
        return float(freq) if isinstance(freq, (int, float)) and not isinstance(freq, bool) and freq > 0 else None

    def language(self) -> str | None:
        text = self.problem_info.get("language_instruction")
        if isinstance(text, list):  # some LIBERO files store it as a list of words
            text = " ".join(str(t) for t in text)
        return text.strip() if isinstance(text, str) and text.strip() else None

    def episodes(self) -> Iterator[RobomimicEpisode]:
        meta_attrs: dict[str, Any] = {"env_args": self.env_args}
        if self.problem_info:
            meta_attrs["problem_info"] = self.problem_info
        env = attr_scalar(self.data, "env")  # robosuite's gather_demonstrations_as_hdf5: the env name
        if isinstance(env, (str, bytes)):
            meta_attrs["env"] = env.decode("utf-8", "replace") if isinstance(env, bytes) else env
        demos = sorted((k for k in self.data if k.startswith("demo")), key=natural_key)
        for key, split in split_order(self.f, demos, self.path):
            group = member(self.data, key, self.path)
            if not isinstance(group, h5py.Group):
                raise DatasetError(f"{self.path}: data/{key}: not a group", code="dataset.source.invalid")
            language = _demo_language(group, self.path) or self.language()
            yield RobomimicEpisode(self.path, group, EpisodeMeta(language, dict(meta_attrs), split=split))

    def close(self) -> None:
        self.f.close()


def _demo_language(group: h5py.Group, path: Path) -> str | None:
    """A demo's own language instruction: ``ep_meta`` JSON's ``lang`` (RoboCasa's and robomimic 0.5's per-demo
    metadata; `export --to robomimic` writes it too), None when it has none."""
    meta = json_attr(group, "ep_meta", path)
    text = meta.get("lang") if isinstance(meta, dict) else None
    return text.strip() if isinstance(text, str) and text.strip() else None


def split_order(f: h5py.File, demos: list[str], path: Path) -> list[tuple[str, str | None]]:
    """The demos with their split, grouped by split: robomimic's filter keys `mask/train` then `mask/valid`
    (its split_train_val script writes them: arrays of demo names), then the demos in neither (no split). Without
    those keys: every demo in order, no split. Other filter keys (`20_percent`, ...) are not splits."""
    mask = f.get("mask")
    named: dict[str, list[str]] = {}
    if isinstance(mask, h5py.Group):
        for split in SPLITS:
            if split in mask:
                named[split] = _demo_names(member(mask, split, path), path)
    if not named:
        return [(d, None) for d in demos]
    known = set(demos)
    out: list[tuple[str, str | None]] = []
    for split, names in named.items():
        out += [(d, split) for d in sorted(set(names) & known - {d for d, _ in out}, key=natural_key)]
    placed = {d for d, _ in out}
    return out + [(d, None) for d in demos if d not in placed]


def _demo_names(ds: Any, path: Path) -> list[str]:
    where = f"{path}: {getattr(ds, 'name', '?').lstrip('/')}"
    if not isinstance(ds, h5py.Dataset) or len(ds.shape) != 1 or ds.dtype.kind not in "SO":
        raise DatasetError(f"{where}: not a list of demo names", code="dataset.source.invalid")
    if ds.shape[0] > MAX_DEMOS:
        raise DatasetError(f"{where}: {ds.shape[0]} names (over {MAX_DEMOS})", code="dataset.source.shape")
    try:
        values = ds[()]
    except (OSError, ValueError, RuntimeError, TypeError) as exc:
        raise DatasetError(f"{where}: cannot read: {exc}", code="dataset.source.read") from None
    return [v.decode("utf-8", "replace") if isinstance(v, bytes) else str(v) for v in values]


def open_robomimic(path: Path) -> RobomimicFile | None:
    """The file as a robomimic-family source, or None when it is HDF5 of another layout."""
    f = open_file(path)
    layout = robomimic_layout(f)
    if layout is None:
        f.close()
        return None
    return RobomimicFile(path, f, layout)
