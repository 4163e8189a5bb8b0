"""Quick start-up: the command line imports only what the command run needs. `import openral_data.cli.app`
(which every call pays) and `--version` load typer and rich, none of the numeric, video, simulator or learning
libraries; `info` and `doctor` read parquet and video, but never torch, lerobot, pyarrow.dataset (and the pandas
it imports), MuJoCo, rerun or matplotlib. Each case runs in a fresh interpreter (a test process has them all
loaded); the timings are benchmarks/bench_startup.py's."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from openral_data import manifests
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


def _run(*args: str, watch: tuple[str, ...], env: dict[str, str] | None = None) -> tuple[str, list[str]]:
    """What the command printed on stdout, and which of the modules `watch` names it imported."""
    done = subprocess.run(
        [sys.executable, "-c", _PROBE, json.dumps(watch), *args],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
        env=None if env is None else {**os.environ, **env},
    )
    assert done.returncode == 0, done.stderr
    *printed, last = done.stdout.splitlines()
    report = json.loads(last)
    assert report["code"] in (0, None), done.stdout + done.stderr
    return "\n".join(printed), list(report["loaded"])


def _loaded(*args: str, watch: tuple[str, ...]) -> list[str]:
    return _run(*args, watch=watch)[1]


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
    # nor the other commands, the writer, PyAV, DuckDB or the quality measures (no quality table to count)
    others = ("openral_data.cli.record", "openral_data.cli.browse", "openral_data.formats.lerobot_v3.writer")
    measures = ("openral_data.metrics.quality.table", "openral_data.metrics.quality.view")
    watch = (*CONVERT_STACK, *others, *measures, "av", "duckdb", "pyarrow.compute")
    assert _loaded("info", str(small), watch=watch) == []
    # `list` reads manifests: not even the parquet/video libraries (`runs here` checks no checkpoint by decoding)
    assert _loaded("list", watch=(*CONVERT_STACK, *READING_FREE, "av", "pyarrow", "duckdb")) == []


def test_list_scenes_answers_from_its_cache_until_a_file_changes(tmp_path: Path) -> None:
    """`list` keeps what it found in each manifest (manifests.cache_home()): unchanged files are not parsed again
    (no YAML, no pydantic schemas), a changed one is, and what is listed is the file as it is now."""
    env = {"XDG_CACHE_HOME": str(tmp_path / "cache"), "OPENRAL_DATA_HOME": str(tmp_path)}
    mine = tmp_path / "scenes" / "my_pick.yaml"
    mine.parent.mkdir()
    builtin = manifests.builtin_dir() / "scenes" / "sim" / "mock_pick.yaml"
    mine.write_text(builtin.read_text().replace("id: mock_pick", "id: my_pick"))
    watch = ("yaml", "openral_data.schemas", "numpy", "openral_data.cli.record", "openral_data.cli.convert")
    _, first = _run("list", "scenes", watch=watch, env=env)
    assert first == ["openral_data.schemas", "yaml"]  # nothing cached yet: every manifest read and validated
    assert list((tmp_path / "cache" / "openral-data").glob("catalog-*.json"))
    printed, again = _run("list", "scenes", "--json", watch=watch, env=env)
    assert again == []  # every manifest unchanged: the cache answers, no other command's module imported
    scenes = {s["id"]: s for s in json.loads(printed)["scenes"]}
    assert scenes["my_pick"]["robot"] == "mock_arm" and scenes["my_pick"]["origin"] == "project"
    assert scenes["tabletop_push"]["robot"] == "franka_panda" and scenes["tabletop_push"]["error"] is None
    mine.write_text(mine.read_text().replace("robot: mock_arm", "robot: franka_panda").replace("fps: 20", "fps: 0"))
    printed, changed = _run("list", "scenes", "--json", watch=watch, env=env)
    assert changed == ["openral_data.schemas", "yaml"]  # the changed file read again
    mine_now = {s["id"]: s for s in json.loads(printed)["scenes"]}["my_pick"]
    assert mine_now["robot"] is None and "fps" in mine_now["error"]  # as it is now: invalid, saying why
