"""One success rule (`formats.lerobot_v3.success`): `info`, `stats` and `view` agree on every kind of dataset —
ours (`openral.success`), lerobot's with per-frame `next.success` (any frame), lerobot's without (unknown), and a
converted one whose source said nothing (unknown, never 0 %)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from rerun.chunk import RrdReader

from openral_data.viz.rerun_view import ViewOptions, run_view
from tests.support.bags import MAPPING, write_ros2
from tests.support.cli import run_cli
from tests.support.lerobot_written import SUCCEEDED, write_lerobot_dataset
from tests.support.recorded import record_mock_cli
from tests.support.scenes import write_yaml


def _info(root: Path) -> tuple[dict[str, object], str]:
    doc = run_cli("info", str(root), "--json")
    text = run_cli("info", str(root))
    assert doc.returncode == 0 and text.returncode == 0, doc.stderr + text.stderr
    line = next(ln for ln in text.stdout.splitlines() if "success rate" in ln)
    return json.loads(doc.stdout), line


def _stats(root: Path) -> list[bool | None]:
    proc = run_cli(
        "stats", str(root), "--sql", "SELECT success FROM episodes ORDER BY episode_index", "--format", "json"
    )
    assert proc.returncode == 0, proc.stderr
    return [r["success"] for r in json.loads(proc.stdout)["sql"]]


def _view_event(root: Path, episode: int, rrd: Path) -> str:
    run_view(ViewOptions(root, episode=episode, save=rrd))
    texts = []
    for chunk in RrdReader(rrd).stream():
        if chunk.entity_path == "/events":
            texts.append(str(chunk.to_record_batch()))
    return "\n".join(texts)


def _agree(root: Path, expected: list[bool | None], tmp_path: Path) -> str:
    doc, line = _info(root)
    known = [v for v in expected if v is not None]
    assert doc["success_known"] is bool(known)
    assert doc["successes"] == (sum(known) if known else None)
    rate = sum(known) / len(known) if known else None
    assert doc["success_rate"] == (None if rate is None else pytest.approx(rate, rel=1e-11))  # --json rounds floats
    assert _stats(root) == expected
    for e, value in enumerate(expected):
        label = "unknown" if value is None else ("success" if value else "failure")
        assert f"episode {e} done: {label}" in _view_event(root, e, tmp_path / f"{root.name}-{e}.rrd")
    return line


@pytest.mark.slow
def test_ours(tmp_path: Path) -> None:
    root = record_mock_cli(tmp_path, [3, 1000], max_steps=8)
    line = _agree(root, [True, False], tmp_path)
    assert "50.0% (1/2)" in line


@pytest.mark.slow
@pytest.mark.parametrize("with_success", [True, False])
def test_lerobot_written(tmp_path: Path, with_success: bool) -> None:
    root = tmp_path / "lr"
    write_lerobot_dataset(root, with_success)
    line = _agree(root, list(SUCCEEDED) if with_success else [None] * len(SUCCEEDED), tmp_path)
    assert ("66.7% (2/3)" in line) if with_success else (line.split(None, 2)[-1] == "unknown (3 episodes)")


@pytest.mark.slow
def test_converted_without_success_is_unknown(tmp_path: Path) -> None:
    bag = write_ros2(tmp_path / "log", "mcap", duration_ms=1000)
    out = tmp_path / "ds"
    proc = run_cli(
        "convert", str(bag), str(out), "--mapping", str(write_yaml(tmp_path / "m.yaml", MAPPING)), "--codec", "h264"
    )
    assert proc.returncode == 0, proc.stderr
    line = _agree(out, [None], tmp_path)
    assert line.split(None, 2)[-1] == "unknown (1 episode)" and "0.0%" not in line


def test_an_episodes_table_without_integer_indices_is_one_line(tmp_path: Path) -> None:
    import pyarrow as pa

    from openral_data.errors import DatasetError
    from openral_data.formats.lerobot_v3.success import episode_successes

    for table in (pa.table({"length": [3]}), pa.table({"episode_index": [None]}), pa.table({"episode_index": ["0"]})):
        with pytest.raises(DatasetError) as err:
            episode_successes(tmp_path, table)
        assert err.value.code == "dataset.invalid" and "episode_index" in str(err.value)


def test_frame_successes_are_aggregated_per_episode_across_files(tmp_path: Path) -> None:
    """lerobot's rule over several data files: an episode split across two files succeeded if any of its frames
    did, in either file; `next.success` as shape-(1,) lists and NULLs (no success) are read alike."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    from openral_data.errors import DatasetError
    from openral_data.formats.lerobot_v3.success import episode_successes

    (tmp_path / "data/chunk-000").mkdir(parents=True)
    frames = pa.list_(pa.bool_())
    pq.write_table(
        pa.table(
            {
                "episode_index": [0, 0, 1, 1, 2],
                "next.success": pa.array([[False], [True], [False], [None], [False]], frames),
            }
        ),
        tmp_path / "data/chunk-000/file-000.parquet",
    )
    pq.write_table(
        pa.table({"episode_index": [2, 2, 3], "next.success": pa.array([[False], [True], [False]], frames)}),
        tmp_path / "data/chunk-000/file-001.parquet",
    )
    episodes = pa.table({"episode_index": [0, 1, 2, 3, 4]})
    assert episode_successes(tmp_path, episodes) == {0: True, 1: False, 2: True, 3: False, 4: None}

    pq.write_table(
        pa.table({"episode_index": [4.0], "next.success": pa.array([[True]], frames)}),
        tmp_path / "data/chunk-000/file-002.parquet",
    )
    with pytest.raises(DatasetError) as err:
        episode_successes(tmp_path, episodes)
    assert err.value.code == "dataset.invalid" and str(err.value).endswith("episode_index: not all integers")
