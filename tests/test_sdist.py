"""The source archive `uv build` makes leaves out what a checkout accumulates: recordings under datasets/ (whose
own .gitignore hatch does not read), runs/ and results/. Built from this pyproject.toml in a scratch project
holding a file in each of those folders; skipped without uv, or offline without hatchling in uv's cache."""

from __future__ import annotations

import shutil
import subprocess
import tarfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent


def test_the_sdist_leaves_out_recordings_and_outputs(tmp_path: Path) -> None:
    uv = shutil.which("uv")
    if uv is None:
        pytest.skip("uv is not installed")
    project = tmp_path / "project"
    for name in ("pyproject.toml", "README.md", "datasets/.gitignore", "datasets/README.md"):
        (project / name).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy(ROOT / name, project / name)
    (project / "openral_data").mkdir()
    (project / "openral_data/__init__.py").write_text("")
    (project / "pipelines").mkdir()
    for kept in ("datasets/demo-1/meta/info.json", "runs/r/report.json", "results/replay-a/summary.json"):
        (project / kept).parent.mkdir(parents=True, exist_ok=True)
        (project / kept).write_text("{}")
    done = subprocess.run(
        [uv, "build", "--sdist", "--offline", "--out-dir", str(tmp_path / "dist"), str(project)],
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
    )
    if done.returncode != 0 and "offline" in done.stderr.lower():
        pytest.skip(f"no hatchling in uv's cache (offline): {done.stderr.strip().splitlines()[-1]}")
    assert done.returncode == 0, done.stderr
    (archive,) = (tmp_path / "dist").glob("*.tar.gz")
    with tarfile.open(archive) as tar:
        names = [name.split("/", 1)[1] for name in tar.getnames() if "/" in name]
    assert "pyproject.toml" in names and "openral_data/__init__.py" in names
    assert not [n for n in names if n.split("/")[0] in ("datasets", "runs", "results")], names
