"""Nothing is published that lerobot 0.6.1 cannot load (`loadable.check_loadable`, run by `Staging.publish` and
`Staging.replace_existing`): a command whose output lerobot could not load refuses in one line (exit 2,
``dataset.unloadable``) and leaves nothing under the output's name, nor a hidden staging folder."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from openral_data.errors import DatasetError
from openral_data.formats.staging import Staging
from tests.support.inproc import run_inproc
from tests.support.legacy_v2 import write_v2


def _nothing_published(out: Path) -> None:
    assert not out.exists()
    assert [p.name for p in out.parent.iterdir() if p.name.startswith(f".{out.name}")] == []


@pytest.mark.slow  # runs lerobot's converter
def test_upgrade_refuses_an_output_lerobot_cannot_load(tmp_path: Path, publish_load: None) -> None:
    """A v2.1 dataset whose last frame names task 7 of 2: lerobot's converter converts it and upgrade used to
    publish it (exit 0); lerobot's loader then fails on that frame. Now refused, naming the file and frame."""
    old = write_v2(tmp_path / "old")
    path = old / "data/chunk-000/episode_000002.parquet"
    table = pq.read_table(path)
    i = table.schema.get_field_index("task_index")
    tasks = table.column("task_index").to_pylist()
    tasks[-1] = 7
    pq.write_table(table.set_column(i, table.schema.field(i), pa.array(tasks, pa.int64())), path)
    new = tmp_path / "new"
    res = run_inproc("upgrade", "-q", str(old), str(new))
    assert res.returncode == 2, res.stdout
    assert res.stderr == (
        f"error: {new}/data/chunk-000/file-000.parquet: lerobot 0.6.1 cannot load frame 15: IndexError: single "
        "positional indexer is out-of-bounds; not published (lerobot 0.6.1 could not load it)\n"
    )
    _nothing_published(new)


@pytest.fixture(scope="module")
def v3(tmp_path_factory: pytest.TempPathFactory) -> Path:
    work = tmp_path_factory.mktemp("v3")
    old = write_v2(work / "old", lengths=(3, 4))
    assert run_inproc("upgrade", "-q", str(old), str(work / "new")).returncode == 0
    return work / "new"


def _publish(src: Path, out: Path, edit: object) -> None:
    staging = Staging(out, "test")
    with staging as folder:
        shutil.copytree(src, folder, dirs_exist_ok=True)
        edit(folder)  # type: ignore[operator]
        staging.publish()


def _undeclared_column(folder: Path) -> None:
    path = folder / "data/chunk-000/file-000.parquet"
    table = pq.read_table(path)
    pq.write_table(table.append_column("extra", pa.array([0.0] * table.num_rows)), path)


def _without_default_feature(folder: Path) -> None:
    info = json.loads((folder / "meta/info.json").read_text())
    del info["features"]["task_index"]
    (folder / "meta/info.json").write_text(json.dumps(info))


@pytest.mark.parametrize(
    ("edit", "said"),
    [
        (_undeclared_column, "data/chunk-000/file-000.parquet: columns: column(s) extra not declared in info.json"),
        (_without_default_feature, "meta/info.json: features: lerobot's default feature(s) task_index missing"),
    ],
)
def test_a_staged_dataset_lerobot_cannot_load_is_not_published(
    v3: Path, tmp_path: Path, edit: object, said: str
) -> None:
    out = tmp_path / "out"
    with pytest.raises(DatasetError) as refused:
        _publish(v3, out, edit)
    assert refused.value.code == "dataset.unloadable" and str(refused.value).startswith(f"{out}/{said}")
    _nothing_published(out)
    _publish(v3, out, lambda folder: None)  # the same dataset untouched is published
    assert (out / "meta/info.json").is_file()
