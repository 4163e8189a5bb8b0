"""A scene whose simulator extra is not installed is refused by `record` at once, before the scene is built or
the policy loaded (that build's own import error used to come only after the policy load), in one line naming
the extra and both ways to install it; nothing is created at `--out`. The extra is hidden from this process by
an import finder that finds nothing under its name (as in an environment without it)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

_RUN = """
import sys
class Absent:
    def find_spec(self, name, path=None, target=None):
        if name.split(".")[0] == "gym_pusht":
            raise ModuleNotFoundError(f"No module named {name!r}", name=name)
sys.meta_path.insert(0, Absent())
sys.argv = ["openral-data", *sys.argv[1:]]
from openral_data.cli import main
import openral_data.record.start as start
def never(*args, **kwargs):
    raise AssertionError("the scene was built / the policy loaded")
start.start = never
import openral_data.record.sim as sim
sim.start = never
main()
"""


def test_a_missing_simulator_extra_is_said_before_anything_starts(tmp_path: Path) -> None:
    out = tmp_path / "ds"
    done = subprocess.run(
        [sys.executable, "-c", _RUN, "record", "--scene", "pusht", "--n-episodes", "1", "--out", str(out)],
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
    )
    assert done.returncode == 2, done.stderr
    (line,) = done.stderr.splitlines()
    assert line.startswith("error: ") and line.endswith(
        "pusht.yaml: scene.type: gym_pusht: needs the 'pusht' extra: "
        "pip install 'openral-data[pusht]' (in a checkout: uv sync --extra pusht)"
    )
    assert not out.exists()
