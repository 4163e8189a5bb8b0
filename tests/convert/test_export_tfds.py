"""`export --to rlds` loaded by TensorFlow Datasets itself (#47): `tfds.builder_from_directory(OUT)`, no code of
ours, lists the dataset's splits and decodes every episode to the dataset's numbers, language and step flags
exactly and its pictures within JPEG's tolerance.

TensorFlow is not in .venv: tfds runs in .venv-tfds (`bash scripts/setup_tfds.sh`; .ci/run makes it and runs this
file with OPENRAL_REQUIRE_TFDS=1), reading the export in a subprocess (tests/support/tfds_load.py). Without that
environment the test is skipped, unless OPENRAL_REQUIRE_TFDS=1 says it must run.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

from tests.support.exported import close_pictures, read_elsewhere, source_episodes, splits_dataset
from tests.support.inproc import run_inproc

ROOT = Path(__file__).resolve().parents[2]
TFDS_PYTHON = Path(os.environ.get("OPENRAL_TFDS_PYTHON", ROOT / ".venv-tfds" / "bin" / "python"))


@pytest.mark.slow  # TensorFlow's import alone takes half a minute
def test_tfds_loads_the_rlds_export(tmp_path: Path) -> None:
    if not TFDS_PYTHON.is_file():
        if os.environ.get("OPENRAL_REQUIRE_TFDS") == "1":
            pytest.fail(f"{TFDS_PYTHON}: missing (bash scripts/setup_tfds.sh makes it)")
        pytest.skip("no .venv-tfds (bash scripts/setup_tfds.sh)")
    dataset = splits_dataset(tmp_path)
    out = tmp_path / "my_robot_data"
    run = run_inproc("export", str(dataset), "--to", "rlds", str(out))
    assert run.returncode == 0, run.stderr
    npz = tmp_path / "tfds.npz"
    env = {**os.environ, "TF_CPP_MIN_LOG_LEVEL": "2", "CUDA_VISIBLE_DEVICES": ""}
    read_elsewhere(TFDS_PYTHON, "tfds_load.py", [str(out), str(npz)], env)
    got = np.load(npz)
    assert got["splits"].tolist() == ["train", "val"]
    episodes = source_episodes(dataset)
    order = [("train", i) for i in range(3)] + [("val", i) for i in range(2)]
    assert sorted({k.rsplit("|", 1)[0] for k in got.files if "|" in k}) == [f"{s}|{i}" for s, i in order]
    for (split, i), want in zip(order, episodes, strict=True):
        step = {k.split("|", 2)[2]: got[k] for k in got.files if k.startswith(f"{split}|{i}|")}
        n = len(want.state)
        assert step["episode_metadata/episode_index"] == want.index
        assert step["episode_metadata/success"] == 1 and step["episode_metadata/seed"] == want.index
        assert step["steps/observation/state"].dtype == np.float32
        assert np.array_equal(step["steps/observation/state"], want.state)
        assert np.array_equal(step["steps/action"], want.action)
        assert np.array_equal(step["steps/reward"], want.reward)
        assert step["steps/discount"].tolist() == [1.0] * n
        assert step["steps/is_first"].tolist() == [True] + [False] * (n - 1)
        assert step["steps/is_last"].tolist() == [False] * (n - 1) + [True]
        assert step["steps/is_terminal"].tolist() == want.success.tolist()
        assert [t.decode() for t in step["steps/language_instruction"]] == [want.task] * n
        for camera, pictures in want.pictures.items():
            close_pictures(step[f"steps/observation/{camera}"], pictures)
