"""`export --to robomimic` read by robomimic's own `SequenceDataset` (#47): each filter key (split) selects its
demos, and every sample's action, reward, done, state and pictures equal the dataset's (pictures exactly: the
file holds the decoded frames).

robomimic is not in .venv (it pins its own torch stack): set OPENRAL_ROBOMIMIC_PYTHON to a Python that has it
(`uv venv /tmp/rm && uv pip install --python /tmp/rm/bin/python robomimic six`; robomimic 0.3.0 imports `six`
without declaring it); without it the test is skipped. It reads the export in a subprocess
(tests/support/robomimic_load.py).
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import pytest

from tests.support.exported import read_elsewhere, source_episodes, splits_dataset
from tests.support.inproc import run_inproc

PYTHON = os.environ.get("OPENRAL_ROBOMIMIC_PYTHON")


@pytest.mark.slow  # robomimic imports torch in its own environment
@pytest.mark.skipif(not PYTHON, reason="OPENRAL_ROBOMIMIC_PYTHON: no Python with robomimic given")
def test_robomimic_sequence_dataset_reads_the_export(tmp_path: Path) -> None:
    dataset = splits_dataset(tmp_path)
    out = tmp_path / "demos.hdf5"
    run = run_inproc("export", str(dataset), "--to", "robomimic", str(out))
    assert run.returncode == 0, run.stderr
    npz = tmp_path / "read.npz"
    assert PYTHON is not None
    read_elsewhere(
        PYTHON, "robomimic_load.py", [str(out), str(npz), "state", "--rgb", "image_image", "wrist_image"], cwd=tmp_path
    )
    got = np.load(npz)
    assert json.loads(str(got["env_meta"]))["env_kwargs"]["control_freq"] == 5
    episodes = source_episodes(dataset)
    for split, group, demos in (("train", episodes[:3], [0, 1, 2]), ("valid", episodes[3:], [3, 4])):
        assert got[f"{split}|demos"].tolist() == [f"demo_{k}" for k in demos]
        i = 0
        for episode in group:
            n = len(episode.state)
            for t in range(n):
                assert np.array_equal(got[f"{split}|{i}|actions"], episode.action[t])
                assert np.array_equal(got[f"{split}|{i}|obs/state"], episode.state[t])
                assert got[f"{split}|{i}|rewards"] == episode.reward[t] and got[f"{split}|{i}|dones"] == (t == n - 1)
                for camera, pictures in episode.pictures.items():
                    assert np.array_equal(got[f"{split}|{i}|obs/{camera}_image"], pictures[t])
                i += 1
