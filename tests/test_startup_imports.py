"""Quick start-up: the command line imports only what the command run needs. `import openral_data.cli.app`
(which every call pays) and `--version` load typer and rich, none of the numeric, video, simulator or learning
libraries; `info` and `doctor` read parquet and video, but never torch, lerobot, pyarrow.dataset (and the pandas
it imports), MuJoCo, rerun or matplotlib. Each case runs in a fresh interpreter (a test process has them all
loaded); the timings are benchmarks/bench_startup.py's."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from tests.support.recorded import record_small

# what no command needs merely to start, nor `--version` at all
STARTUP_FREE = (
    "torch",
    "lerobot",
    "pandas",
    "pyarrow",
    "pyarrow.dataset",
    "numpy",
    "duckdb",
    "av",
    "mujoco",
    "rerun",
    "matplotlib",
    "pydantic",
    "huggingface_hub",
)
# what `info DATASET` and `list` do not need: the convert stack and the bag readers it imports
CONVERT_STACK = ("openral_data.convert", "rosbags", "mcap", "h5py", "zarr")
# what reading a dataset's metadata, or checking it, does not need
READING_FREE = ("torch", "lerobot", "pyarrow.dataset", "mujoco", "rerun", "matplotlib", "huggingface_hub")

# runs the real entry point, then prints which of the modules named in argv[1] were imported
_PROBE = """
import json, sys
watch = json.loads(sys.argv[1])
sys.argv = ["openral-data", *sys.argv[2:]]
try:
    if sys.argv[1:] == ["(import)"]:
        import openral_data.cli.app
    else:
        from openral_data.cli import main
        main()
except SystemExit as exc:
    code = exc.code
else:
    code = 0
print(json.dumps({"code": code, "loaded": sorted(m for m in watch if m in sys.modules)}))
"""


def _loaded(*args: str, watch: tuple[str, ...]) -> list[str]:
    done = subprocess.run(
        [sys.executable, "-c", _PROBE, json.dumps(watch), *args],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    report = json.loads(done.stdout.splitlines()[-1])
    assert report["code"] in (0, None), done.stdout + done.stderr
    return list(report["loaded"])


def test_importing_the_command_line_loads_no_heavy_library() -> None:
    assert _loaded("(import)", watch=STARTUP_FREE) == []


def test_version_loads_no_heavy_library() -> None:
    assert _loaded("--version", watch=STARTUP_FREE) == []


@pytest.fixture(scope="module")
def small(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return record_small(tmp_path_factory.mktemp("startup"))


def test_info_reads_without_pandas_or_learning_libraries(small: Path) -> None:
    assert _loaded("info", str(small), watch=(*READING_FREE, "pandas")) == []


def test_doctor_checks_without_learning_or_simulator_libraries(small: Path) -> None:
    assert _loaded("doctor", str(small), watch=READING_FREE) == []


def test_info_and_list_start_without_the_convert_stack(small: Path) -> None:
    assert _loaded("info", str(small), watch=CONVERT_STACK) == []
    # `list` reads manifests: not even the parquet/video libraries (`runs here` checks no checkpoint by decoding)
    assert _loaded("list", watch=(*CONVERT_STACK, *READING_FREE, "av", "pyarrow", "duckdb")) == []
