"""The documented Python API: `openral_data.__all__` resolves, importing it is cheap, and the docs example runs."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import openral_data

REPO = Path(__file__).resolve().parent.parent
DOC = REPO / "docs" / "python-api.md"


def test_every_public_name_resolves() -> None:
    assert "record" in openral_data.__all__ and "stats_query" in openral_data.__all__
    for name in openral_data.__all__:
        assert getattr(openral_data, name) is not None, name


def test_import_is_cheap() -> None:
    """`import openral_data` loads no submodule until a name is used (simulators stay unloaded)."""
    code = "import sys, openral_data; print(sorted(m for m in sys.modules if m.startswith('openral_data.')))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "['openral_data.version']"


def test_version_is_the_package_metadata() -> None:
    import tomllib

    assert openral_data.__version__ == tomllib.loads((REPO / "pyproject.toml").read_text())["project"]["version"]


def test_docs_example_records_and_reads_back(tmp_path: Path) -> None:
    text = DOC.read_text()
    section = text.split("## Record a mock dataset and read it back", 1)[1]
    match = re.search(r"```python\n(.*?)```", section, re.S)
    assert match is not None
    code = match.group(1)
    assert len(code.strip().splitlines()) <= 10
    env = {k: v for k, v in os.environ.items() if k != "OPENRAL_DATA_HOME"}
    env["OPENRAL_DATA_HOME"] = str(REPO)
    run = subprocess.run(
        [sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True, env=env, check=False
    )
    assert run.returncode == 0, run.stderr
    first = run.stdout.splitlines()[0]
    assert re.fullmatch(
        r"2 episodes, \d+ frames, cameras \['observation.images.front', 'observation.images.wrist'\]", first
    ), first
    assert "'episode_index': 0" in run.stdout and "'episode_index': 1" in run.stdout
    # the written dataset is a real LeRobot v3 dataset
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    ds = LeRobotDataset("api_demo", root=tmp_path / "datasets" / "api_demo")
    assert ds.num_episodes == 2
    assert ds.num_frames == int(first.split()[2])
