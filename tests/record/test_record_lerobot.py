"""End to end: record the mock scene and open the result with lerobot 0.6.1's own loader, frame by frame."""

from __future__ import annotations

import importlib.util
import json
import subprocess
import sys
from pathlib import Path
from typing import Any

import av
import pyarrow.parquet as pq
import pytest

from openral_data.record.options import RecordOptions
from openral_data.record.sim import record
from tests.support.cli import run_cli
from tests.support.home import REPO
from tests.support.lerobot import verify_mock_dataset
from tests.support.scenes import mock_scene, write_yaml

LENGTHS = [5, 9, 3, 7]


def _record(project: Path, tmp_path: Path, codec: str, **scene_over: Any) -> Path:
    scene = write_yaml(
        project / "scenes/sim/mock_test.yaml", mock_scene(success_after=LENGTHS, n_episodes=4, **scene_over)
    )
    out = tmp_path / f"ds_{codec}"
    summary = record(RecordOptions(scene=str(scene), rskill="random-mock", out=out, codec=codec))  # type: ignore[arg-type]
    assert [e.length for e in summary.episodes] == LENGTHS
    assert summary.frames == sum(LENGTHS) and summary.success_rate == 1.0
    return out


@pytest.mark.parametrize("codec", ["av1", "h264"])
def test_lerobot_loads_every_frame_where_it_belongs(project: Path, tmp_path: Path, codec: str) -> None:
    out = _record(project, tmp_path, codec)
    seen = verify_mock_dataset(out, "pyav")
    assert seen["lengths"] == LENGTHS
    starts = [sum(LENGTHS[:k]) for k in range(len(LENGTHS))]
    assert seen["boundaries"] == [(s, s + n) for s, n in zip(starts, LENGTHS, strict=True)]
    assert seen["video_keys"] == ["observation.images.front", "observation.images.wrist"]
    info = json.loads((out / "meta/info.json").read_text())
    assert info["features"]["observation.images.front"]["info"]["video.codec"] == codec
    # the mp4 really is that codec, with exactly one frame per parquet row
    for key in seen["video_keys"]:
        files = sorted((out / "videos" / key).glob("*/*.mp4"))
        assert len(files) == 1  # per-episode files were joined at close
        with av.open(str(files[0])) as c:
            stream = c.streams.video[0]
            assert stream.codec_context.name in {"av1": ("libdav1d", "av1", "libaom-av1"), "h264": ("h264",)}[codec]
            assert sum(1 for p in c.demux(stream) if p.size) == sum(LENGTHS)


def _load_in_subprocess(out: Path, *backend: str) -> tuple[dict[str, Any], list[str]]:
    """lerobot 0.6.1 loads `out` and decodes every frame in a fresh interpreter (as a user's script would);
    returns what it saw and every line of its stdout/stderr that mentions torchcodec."""
    proc = subprocess.run(
        [sys.executable, "-m", "tests.support.lerobot", str(out), *backend],
        cwd=REPO,
        capture_output=True,
        text=True,
        check=False,
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    noise = [line for line in (proc.stdout + proc.stderr).splitlines() if "torchcodec" in line.lower()]
    return json.loads(proc.stdout.strip().splitlines()[-1]), noise


@pytest.mark.slow
def test_lerobot_loads_our_output_without_torchcodec_warnings(project: Path, tmp_path: Path) -> None:
    """torchcodec is not installed (pyproject.toml [tool.uv] override-dependencies): its wheel finds no FFmpeg here
    and every load printed ~40 lines of load failures. We claim the pyav backend, and load with it explicitly."""
    assert importlib.util.find_spec("torchcodec") is None, "torchcodec is installed: re-run scripts/setup.sh"
    out = _record(project, tmp_path, "h264")
    seen, noise = _load_in_subprocess(out, "pyav")
    assert seen["video_backend"] == "pyav" and seen["lengths"] == LENGTHS
    assert noise == []
    # A user's default LeRobotDataset(repo, root=...) picks pyav too, after lerobot's own one-line notice.
    seen, noise = _load_in_subprocess(out)
    assert seen["video_backend"] == "pyav" and seen["lengths"] == LENGTHS
    assert len(noise) == 1 and "falling back to 'pyav'" in noise[0], noise


def test_episode_metadata_keeps_seed_success_and_initial_state(project: Path, tmp_path: Path) -> None:
    scene = write_yaml(project / "scenes/sim/m.yaml", mock_scene(success_after=[3, 50], max_steps=6, n_episodes=2))
    out = tmp_path / "ds"
    summary = record(RecordOptions(scene=str(scene), rskill="zero-mock", out=out, seed=40))
    assert [(e.seed, e.success, e.length) for e in summary.episodes] == [(40, True, 3), (41, False, 6)]
    eps = pq.read_table(out / "meta/episodes/chunk-000/file-000.parquet").to_pylist()
    assert [e["openral.seed"] for e in eps] == [40, 41]
    assert [e["openral.success"] for e in eps] == [True, False]
    assert [json.loads(e["openral.initial_state"]) for e in eps] == [
        {"episode": 0, "seed": 40},
        {"episode": 1, "seed": 41},
    ]
    data = pq.read_table(out / "data/chunk-000/file-000.parquet").to_pydict()
    # per-frame outcome: done on the last row of each episode, success only where it happened
    assert data["next.done"] == [False, False, True] + [False] * 5 + [True]
    assert data["next.success"] == [False, False, True] + [False] * 6
    # failed episodes are kept, and their actions are exactly what the policy emitted (zeros)
    assert all(v == 0.0 for row in data["action"] for v in row)
    provenance = json.loads((out / "meta/openral.json").read_text())
    assert provenance["schema_metadata"]["rskill"]["config"]["id"] == "zero-mock"


def test_cli_record_prints_summary_and_info(project: Path, tmp_path: Path) -> None:
    out = tmp_path / "cli_ds"
    proc = run_cli("record", "--n-episodes", "2", "--max-steps", "8", "--out", str(out))
    assert proc.returncode == 0, proc.stderr
    assert "episodes" in proc.stdout and "success rate" in proc.stdout and str(out.name) in proc.stdout
    assert json.loads((out / "meta/info.json").read_text())["total_episodes"] == 2
    info = run_cli("info", str(out))
    assert info.returncode == 0 and "pick up the mock cube" in info.stdout, info.stderr


def test_default_out_is_a_fresh_folder_under_datasets(project: Path) -> None:
    a = record(RecordOptions(n_episodes=1, max_steps=3))
    b = record(RecordOptions(n_episodes=1, max_steps=3))
    assert a.out.parent == b.out.parent == project / "datasets" and a.out != b.out
