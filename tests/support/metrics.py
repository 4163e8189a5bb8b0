"""Helpers for the stats/view tests: record real mock-scene datasets and make deliberately broken copies."""

from __future__ import annotations

import shutil
from pathlib import Path

import pyarrow as pa
import pyarrow.parquet as pq

from openral_data.record.options import RecordOptions
from openral_data.record.sim import record
from tests.support.home import isolated_home
from tests.support.scenes import mock_scene, write_yaml

# episode lengths; with max_steps=10 an episode whose success_after exceeds 10 fails at step 10
A_SUCCESS_AFTER = [3, 5, 20, 4, 6, 30, 2, 7]  # 6/8 succeed
B_SUCCESS_AFTER = [12, 4, 15, 25, 3, 11]  # 2/6 succeed
MAX_STEPS = 10


def record_datasets(base: Path) -> tuple[Path, Path]:
    """Two real recordings through record(): A = random-mock on scene mock_a, B = zero-mock on mock_b."""
    with isolated_home(base) as home:
        out = []
        for name, rskill, lengths, cams in (
            ("mock_a", "random-mock", A_SUCCESS_AFTER, [("front", 64, 48), ("wrist", 32, 32)]),
            ("mock_b", "zero-mock", B_SUCCESS_AFTER, [("front", 32, 32)]),
        ):
            scene = write_yaml(
                home / f"scenes/sim/{name}.yaml",
                mock_scene(
                    scene_id=name,
                    success_after=lengths,
                    max_steps=MAX_STEPS,
                    n_episodes=len(lengths),
                    cameras=cams,
                ),
            )
            root = base / f"ds_{name}"
            record(RecordOptions(scene=str(scene), rskill=rskill, out=root, codec="h264"))
            out.append(root)
        return out[0], out[1]


def copy_dataset(src: Path, dst: Path) -> Path:
    shutil.copytree(src, dst)
    return dst


def rewrite_parquet(path: Path, table: pa.Table) -> None:
    pq.write_table(table, path)


def data_file(root: Path) -> Path:
    files = sorted((root / "data").glob("*/*.parquet"))
    assert len(files) == 1
    return files[0]


def episodes_file(root: Path) -> Path:
    files = sorted((root / "meta/episodes").glob("*/*.parquet"))
    assert len(files) == 1
    return files[0]
