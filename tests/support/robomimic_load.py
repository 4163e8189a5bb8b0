"""Run by a Python with robomimic installed (not .venv: robomimic pins its own torch stack; e.g. a throwaway
venv with `uv pip install robomimic six`), not by pytest: read a robomimic HDF5 file with robomimic's own
`SequenceDataset` (its training loader, one filter key at a time) and save every sample it returns as one .npz:
`<filter key>|<sample>|<key>` -> the sample's `actions`, `rewards`, `dones` and `obs/<key>` (its first step), and
`<filter key>|demos` -> the demos the key selects; `env_meta` -> `env_args` as robomimic reads it (JSON).

    PYTHON tests/support/robomimic_load.py FILE.hdf5 OUT.npz OBS_KEY... [--rgb RGB_KEY...]
"""

import json
import sys

import numpy as np
from robomimic.utils import file_utils, obs_utils  # type: ignore[import-not-found,unused-ignore]
from robomimic.utils.dataset import SequenceDataset  # type: ignore[import-not-found,unused-ignore]


def main(path: str, target: str, low_dim: list[str], rgb: list[str]) -> None:
    obs_utils.initialize_obs_utils_with_obs_specs({"obs": {"low_dim": low_dim, "rgb": rgb}})
    keys = (*low_dim, *rgb)
    arrays = {"env_meta": np.array(json.dumps(file_utils.get_env_metadata_from_dataset(path)))}
    for split in ("train", "valid"):
        dataset = SequenceDataset(
            hdf5_path=path, obs_keys=keys, dataset_keys=("actions", "rewards", "dones"), load_next_obs=False,
            frame_stack=1, seq_length=1, pad_frame_stack=True, pad_seq_length=True, get_pad_mask=False,
            goal_mode=None, hdf5_cache_mode=None, hdf5_use_swmr=True, hdf5_normalize_obs=False,
            filter_by_attribute=split,
        )  # fmt: skip
        arrays[f"{split}|demos"] = np.array(dataset.demos)
        for i in range(len(dataset)):
            item = dataset[i]
            arrays |= {f"{split}|{i}|{k}": np.asarray(item[k][0]) for k in ("actions", "rewards", "dones")}
            arrays |= {f"{split}|{i}|obs/{k}": np.asarray(item["obs"][k][0]) for k in keys}
    np.savez(target, **arrays)  # type: ignore[arg-type]


if __name__ == "__main__":
    args = sys.argv[3:]
    cut = args.index("--rgb") if "--rgb" in args else len(args)
    main(sys.argv[1], sys.argv[2], args[:cut], args[cut + 1 :])
