"""The robomimic layout written (the "Dataset Structure" of robomimic's documentation,
robomimic.github.io/docs/datasets/overview.html): ``data`` with its ``total`` and ``env_args`` (JSON) attributes,
one ``data/demo_N`` group an episode with its ``num_samples`` attribute, ``actions`` (N, A), ``rewards`` (N,),
``dones`` (N,) and ``obs/<key>`` datasets (pictures uint8 (N, H, W, C), channel last), and ``mask/<filter key>``
lists of demo names (robomimic's train / validation splits). `DemoWriter` fills one demo's datasets, created at
their full length, step by step."""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from typing import Any

import h5py
import numpy as np
import numpy.typing as npt

DATA = "data"
MASK = "mask"


def demo_name(number: int) -> str:
    return f"demo_{number}"


class DemoWriter:
    """One ``data/demo_N`` group of `length` steps; `keys` (its datasets' paths under the group) -> (one step's
    shape, dtype). Pictures (3-d steps) are chunked a step at a time and gzip-compressed, as robomimic's own
    extraction script writes them."""

    def __init__(self, data: h5py.Group, name: str, length: int, keys: dict[str, tuple[tuple[int, ...], str]]):
        self.group = data.create_group(name)
        self.length = length
        self._sets: dict[str, h5py.Dataset] = {}
        for key, (shape, dtype) in keys.items():
            picture = len(shape) == 3
            self._sets[key] = self.group.create_dataset(
                key,
                shape=(length, *shape),
                dtype=dtype,
                chunks=(1, *shape) if picture and length else None,
                compression="gzip" if picture and length else None,
            )

    def put(self, t: int, values: dict[str, Any]) -> None:
        """Step `t`'s values (every key's)."""
        for key, value in values.items():
            self._sets[key][t] = value

    def finish(self, attrs: dict[str, Any]) -> None:
        """The demo's attributes: ``num_samples`` and `attrs` (numbers and texts)."""
        self.group.attrs["num_samples"] = self.length
        for key, value in attrs.items():
            self.group.attrs[key] = value


def write_header(f: h5py.File, total: int, env_args: dict[str, Any]) -> None:
    """``data``'s attributes: the number of steps in all demos and the environment's metadata as JSON."""
    data = f.require_group(DATA)
    data.attrs["total"] = total
    data.attrs["env_args"] = json.dumps(env_args)


def write_masks(f: h5py.File, masks: Mapping[str, Sequence[str]]) -> None:
    """``mask/<key>``: each filter key's demo names (byte strings, as robomimic's split_train_val writes them)."""
    group = f.require_group(MASK)
    for key, names in masks.items():
        encoded: npt.NDArray[Any] = np.array([n.encode("utf-8") for n in names], dtype="S")
        group.create_dataset(key, data=encoded)
