"""A small LeRobot dataset to export, and what it holds, for the export tests (`export --to rlds|robomimic`).

`splits_dataset` converts the RLDS fixture of `rlds_written` (64x64 gradient pictures, checkable through lossy
video) with two splits into LeRobot v3: episodes 0-2 `train`, 3-4 `val`, each with its own language instruction
("pick up block 2", ... : the source's numbering), a reward, success on the last step, two cameras (`image`,
`wrist`). `source_episodes` reads it back as it is stored: the numbers from the data parquet (lerobot's columns),
the pictures decoded from its videos, the task text of each frame, the splits from info.json.
"""

from __future__ import annotations

import json
import subprocess
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq

from tests.support.inproc import run_inproc
from tests.support.rlds_written import write_rlds

SPLITS = {"train": "0:3", "val": "3:5"}
CAMERAS = ("image", "wrist")


def splits_dataset(tmp: Path) -> Path:
    src = write_rlds(tmp / "toy_rlds" / "1.0.0", splits={"val": ((2, 3),), "train": ((2,), (3, 2))}, smooth=True)
    out = tmp / "lerobot"
    run = run_inproc("convert", str(src), str(out), "--fps", "5", "--codec", "h264")
    assert run.returncode == 0, run.stderr
    assert json.loads((out / "meta/info.json").read_text())["splits"] == SPLITS
    return out


@dataclass
class Episode:
    index: int
    state: np.ndarray
    action: np.ndarray
    reward: np.ndarray
    success: np.ndarray
    task: str
    pictures: dict[str, np.ndarray]  # camera -> (n, H, W, 3) uint8, as decoded from the dataset's videos


def source_episodes(root: Path) -> list[Episode]:
    """Every episode of the dataset at `root`, in episode order (see the module docstring)."""
    from openral_data.convert.export_source import read_export_source

    data = pq.read_table(root / "data").sort_by([("episode_index", "ascending"), ("frame_index", "ascending")])
    cols = data.to_pydict()
    tasks = pq.read_table(root / "meta/tasks.parquet").to_pylist()
    text = {int(r["task_index"]): r.get("task") or r.get("__index_level_0__") for r in tasks}
    source = read_export_source(root)
    out = []
    for row in source.rows:
        e = int(row["episode_index"])
        rows = [i for i, v in enumerate(cols["episode_index"]) if v == e]
        frames = list(source.frames(row))
        out.append(
            Episode(
                e,
                np.array([cols["observation.state"][i] for i in rows], np.float32),
                np.array([cols["action"][i] for i in rows], np.float32),
                np.array([cols["next.reward"][i] for i in rows], np.float32),
                np.array([cols["next.success"][i] for i in rows], bool),
                text[int(cols["task_index"][rows[0]])],
                {c: np.stack([f.images[c] for f in frames]) for c in CAMERAS},
            )
        )
    return out


def close_pictures(got: np.ndarray, want: np.ndarray, mean: float = 3.0) -> None:
    """Pictures equal within a lossy codec's tolerance (mean absolute difference in levels)."""
    assert got.shape == want.shape and got.dtype == np.uint8
    assert np.abs(got.astype(np.int16) - want.astype(np.int16)).mean() < mean


def read_elsewhere(
    python: Path | str, loader: str, args: list[str], env: dict[str, str] | None = None, cwd: Path | None = None
) -> None:
    """Run `tests/support/<loader>` with another environment's interpreter (`.venv-tfds`, a robomimic venv), the
    other ecosystem's own reader inside, on `args` (it writes what it read to an .npz named there)."""
    script = Path(__file__).resolve().parent / loader
    done = subprocess.run(
        [str(python), str(script), *args], check=False, capture_output=True, text=True, env=env, timeout=600, cwd=cwd
    )
    assert done.returncode == 0, done.stderr[-3000:]
