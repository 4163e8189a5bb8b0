"""Run by .venv-tfds's Python (scripts/setup_tfds.sh), not by pytest: load an RLDS build folder with TensorFlow
Datasets itself (`tfds.builder_from_directory`, no code of ours) and save what it decodes, every split's every
episode, as one .npz: `<split>|<episode>|<key>` -> the key's values stacked over the steps (``steps/...``) or the
episode's one value (``episode_metadata/...``), and `splits` -> the split names tfds lists.

    .venv-tfds/bin/python tests/support/tfds_load.py BUILD_DIR OUT.npz
"""

import sys
from typing import Any

import numpy as np
import tensorflow_datasets as tfds  # type: ignore[import-not-found,unused-ignore]  # in .venv-tfds only


def _flat(prefix: str, tree: dict[str, Any], out: dict[str, list[Any]]) -> None:
    for key, value in tree.items():
        if isinstance(value, dict):
            _flat(f"{prefix}/{key}", value, out)
        else:
            out.setdefault(f"{prefix}/{key}", []).append(value)


def main(folder: str, target: str) -> None:
    builder = tfds.builder_from_directory(folder)
    arrays = {"splits": np.array(sorted(builder.info.splits.keys()))}
    for split in builder.info.splits:
        for i, episode in enumerate(tfds.as_numpy(builder.as_dataset(split=split, shuffle_files=False))):
            steps: dict[str, list[Any]] = {}
            for step in episode["steps"]:
                _flat("steps", step, steps)
            arrays |= {f"{split}|{i}|{k}": np.stack([np.asarray(v) for v in vs]) for k, vs in steps.items()}
            meta: dict[str, list[Any]] = {}
            _flat("episode_metadata", episode["episode_metadata"], meta)
            arrays |= {f"{split}|{i}|{k}": np.asarray(vs[0]) for k, vs in meta.items()}
    np.savez(target, **arrays)  # type: ignore[arg-type]


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
