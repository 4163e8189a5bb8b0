"""The v3 layout variants lerobot 0.6.1 loads, read by `formats/lerobot_v3/variants.py` (one place for every
command): tasks.parquet with the task as pandas index `task` (lerobot >= 0.5), as older lerobot's unnamed index
`__index_level_0__`, or as a plain `task` column; a camera's `channel`/`channels` names; a legacy `video_info`
block; depth flagged the legacy way."""

from __future__ import annotations

from pathlib import Path

import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from openral_data.errors import DatasetError
from openral_data.formats.lerobot_v3 import read_tasks
from openral_data.formats.lerobot_v3.tasks_table import tasks_writer
from openral_data.formats.lerobot_v3.variants import (
    comparable,
    feature_info,
    is_depth,
    task_column,
    task_is_index,
    tasks_table,
)

TASKS = ["push the block", "open the drawer", "stack"]


def _write(root: Path, layout: str) -> Path:
    import pandas as pd

    path = root / "meta/tasks.parquet"
    path.parent.mkdir(parents=True, exist_ok=True)
    if layout == "current":  # our writer: the pandas index named `task`, as lerobot 0.6.1 writes it
        tasks_writer({t: i for i, t in enumerate(TASKS)})(path)
    elif layout == "pandas-task":  # lerobot 0.6.1's own write_tasks
        pd.DataFrame({"task_index": range(3)}, index=pd.Index(TASKS, name="task")).to_parquet(path)
    elif layout == "unnamed-index":  # lerobot < 0.5: DataFrame({"task_index": ...}, index=tasks).to_parquet
        pd.DataFrame({"task_index": range(3)}, index=TASKS).to_parquet(path)
    elif layout == "set_index":  # a `task` column made the index with df.set_index, then the name dropped
        df = pd.DataFrame({"task": TASKS, "task_index": range(3)}).set_index("task")
        df.index.name = None
        df.to_parquet(path)
    else:  # a plain column, no pandas metadata (lerobot loads it, but reports the task as a number)
        pq.write_table(pa.table({"task_index": list(range(3)), "task": TASKS}), path)
    return path


@pytest.mark.parametrize("layout", ["current", "pandas-task", "unnamed-index", "set_index", "plain"])
def test_every_tasks_layout_reads_the_same_tasks(tmp_path: Path, layout: str) -> None:
    path = _write(tmp_path, layout)
    schema = pq.read_schema(path)
    assert task_column(schema) == ("task" if layout in ("current", "pandas-task", "plain") else "__index_level_0__")
    assert task_is_index(schema) == (layout != "plain")  # what doctor's `tasks.pandas_index` checks
    assert read_tasks(tmp_path) == TASKS
    assert tasks_table(pq.read_table(path), path).column_names == ["task_index", "task"]


def test_lerobot_reads_the_old_tasks_layout_as_we_do(tmp_path: Path) -> None:
    from lerobot.datasets.io_utils import load_tasks

    _write(tmp_path, "unnamed-index")
    tasks = load_tasks(tmp_path)
    assert [tasks.iloc[i].name for i in range(3)] == read_tasks(tmp_path) == TASKS


def test_a_tasks_table_without_task_text_is_one_error(tmp_path: Path) -> None:
    path = tmp_path / "meta/tasks.parquet"
    path.parent.mkdir(parents=True)
    pq.write_table(pa.table({"task_index": [0], "text": ["x"]}), path)
    with pytest.raises(DatasetError, match=r"tasks.parquet: no column 'task' \(nor the task text as the pandas"):
        read_tasks(tmp_path)
    pq.write_table(pa.table({"task": ["x"]}), path)
    with pytest.raises(DatasetError, match="no column 'task_index'"):
        read_tasks(tmp_path)


def test_camera_spellings_compare_equal() -> None:
    info = {"video.codec": "h264", "video.fps": 10}
    current = {"dtype": "video", "shape": [32, 32, 3], "names": ["height", "width", "channels"], "info": info}
    old = {"dtype": "video", "shape": [32, 32, 3], "names": ["height", "width", "channel"], "video_info": info}
    both = {**current, "video_info": {"video.codec": "h264"}}
    assert feature_info(old) == feature_info(current) == feature_info(both) == info
    assert comparable({"cam": old}) == comparable({"cam": current}) == comparable({"cam": both})
    first = {**old, "shape": [3, 32, 32], "names": ["channel", "height", "width"]}
    assert comparable({"cam": first}) == comparable({"cam": {**current, "names": None}}) == comparable({"cam": current})
    other = {**current, "shape": [32, 32, 1]}
    assert comparable({"cam": other}) != comparable({"cam": current})


@pytest.mark.parametrize(
    ("feature", "depth"),
    [
        ({"info": {"is_depth_map": True}}, True),
        ({"info": {"video.is_depth_map": True}}, True),
        ({"video_info": {"video.is_depth_map": True}}, True),
        ({"info": {"is_depth_map": False}}, False),
        ({}, False),
    ],
)
def test_depth_is_read_as_lerobot_reads_it(feature: dict[str, object], depth: bool) -> None:
    from lerobot.datasets.dataset_metadata import LeRobotDatasetMetadata

    assert is_depth(feature) == depth
    meta = LeRobotDatasetMetadata.__new__(LeRobotDatasetMetadata)
    meta.info = type("Info", (), {"features": {"cam": {"dtype": "video", **feature}}})()
    assert (meta.depth_keys == ["cam"]) == depth
