"""The source registry (`convert.kinds`) is the one place that says what a source is: every kind declares all
its parts, `info` and `convert` pick the same kind for each source (in the one order the registry documents),
and the Python API and a pipeline's convert step take the array sources the command line takes."""

from __future__ import annotations

import inspect
import json
import re
from pathlib import Path
from typing import Any

import h5py
import numpy as np
import pyarrow.parquet as pq
import pytest
import yaml
import zarr

import openral_data
from openral_data.convert import kinds
from openral_data.convert.entry import plan
from openral_data.convert.kinds.base import Request, SourceKind
from openral_data.formats.lerobot_v3.encoder import VideoSettings
from openral_data.schemas.mapping import Mapping
from tests.support.bags import MAPPING, write_plain_mcap, write_ros1
from tests.support.hdf5_layouts import write_aloha, write_robomimic
from tests.support.inproc import run_inproc
from tests.support.offline_sources import write_d4rl, write_maniskill
from tests.support.replay_buffer import sample_episodes, write_replay_buffer
from tests.support.rlds_written import write_rlds

PARTS = ("open", "describe", "blocks", "open_block", "starting_mapping", "plan")


def _data(root: Path) -> dict[str, list[object]]:
    return pq.read_table(sorted((root / "data").rglob("*.parquet"))[0]).to_pydict()


def test_every_kind_declares_every_part_once_in_the_documented_order() -> None:
    """Each registered kind is a complete `SourceKind` (no part left abstract), its name unique, and the order the
    registry tries them in is the order its docstring documents."""
    assert list(kinds.KINDS) == ["lerobot-v2", "lerobot-v3", "ros1-bag", "mcap", "rosbag2", "minari", "hdf5-robomimic",
                                 "hdf5-aloha", "hdf5-d4rl", "hdf5-maniskill", "zarr", "rlds"]  # fmt: skip
    for name, kind in kinds.KINDS.items():
        assert isinstance(kind, SourceKind) and not inspect.isabstract(type(kind)), name
        assert kind.name == name and kind.summary
        assert all(callable(getattr(kind, part)) for part in PARTS), name
    documented = re.findall(r"^\d+\. `([a-z0-9-]+)`", kinds.__doc__ or "", re.MULTILINE)
    assert documented == list(kinds.KINDS)


@pytest.fixture(scope="module")
def sources(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    root = tmp_path_factory.mktemp("sources")
    (root / "mixed").mkdir()
    write_ros1(root / "mixed" / "a.bag")
    write_robomimic(root / "mixed" / "b.hdf5", (4,))
    return {
        "hdf5-robomimic": write_robomimic(root / "lift.hdf5", (6, 4)),
        "hdf5-aloha": write_aloha(root / "aloha", (5,)),
        "zarr": write_replay_buffer(root / "pusht.zarr", sample_episodes((5, 3))),
        "rlds": write_rlds(root / "toy_rlds" / "1.0.0", ((4,), (3,))),
        "hdf5-d4rl": write_d4rl(root / "hopper.hdf5"),
        "hdf5-maniskill": write_maniskill(root / "ms" / "trajectory.h5", (3,)),
        "ros1-bag": write_ros1(root / "run.bag"),
        "rosbag2": write_plain_mcap(root / "plain.mcap"),
        "mixed": root / "mixed",  # bags and an HDF5 file: bags, for info and convert alike
    }


def test_info_and_convert_pick_the_same_kind(sources: dict[str, Path], tmp_path: Path) -> None:
    """For every source, the registry's kind is what `info --json` describes and what `convert` plans with: an
    array source's layout, or bags (a folder holding bags and an HDF5 file too, which `convert` used to read as
    HDF5 while `info` listed its bags)."""
    for name, path in sources.items():
        found = kinds.detect(path)
        assert found is not None
        expected = "ros1-bag" if name == "mixed" else name
        assert found.kind.name == expected, path
        run = run_inproc("info", str(path), "--json")
        assert run.returncode == 0, run.stderr
        doc = json.loads(run.stdout)
        is_bags = expected in ("ros1-bag", "rosbag2")
        assert doc["kind"] == ("bag" if is_bags else "arrays"), path
        fps = None if is_bags or name == "hdf5-robomimic" else 10
        mapping = Mapping.model_validate(MAPPING) if is_bags else None
        planned = plan(path, tmp_path / f"out-{name}", Request(mapping=mapping, fps=fps))
        assert planned.unit == ("messages" if is_bags else "steps"), path
        if not is_bags:
            assert doc["layout"] == planned.to_json(_summary(planned))["layout"]


def _summary(planned: object) -> object:
    from openral_data.convert.summary import ConvertSummary

    source = getattr(planned, "source")  # noqa: B009 - an ArrayPlan's
    summary = ConvertSummary(src=source.path, dst=Path("-"))
    summary.source_kind = source.layout
    source.close()
    return summary


def test_python_api_converts_hdf5_with_the_values_h5py_reads(tmp_path: Path) -> None:
    src = write_robomimic(tmp_path / "lift.hdf5", (6, 4))
    dst = tmp_path / "out"
    summary = openral_data.convert(src, dst, video=_h264())
    assert len(summary.episodes) == 2 and summary.frames == 10
    data = _data(dst)
    with h5py.File(src) as f:
        actions = np.concatenate([f[f"data/demo_{e}/actions"][()] for e in (0, 1)])
        keys = ("robot0_eef_pos", "robot0_gripper_qpos")
        steps = [np.concatenate([f[f"data/demo_{e}/obs/{k}"][()] for k in keys], axis=1) for e in (0, 1)]
        state = np.concatenate(steps)
    np.testing.assert_array_equal(np.array(data["action"]), actions.astype(np.float32))
    np.testing.assert_array_equal(np.array(data["observation.state"]), state.astype(np.float32))


def test_python_api_converts_zarr_and_rlds_with_a_mapping_and_fps(tmp_path: Path) -> None:
    """A Zarr store with `fps` and a mapping given as data; an RLDS folder with `fps`."""
    store = write_replay_buffer(tmp_path / "pusht.zarr", sample_episodes((5, 3)))
    mapping = {"fps": 10, "task": "push the T", "state": {"topic": "data/state"}, "action": {"topic": "data/action"}}
    summary = openral_data.convert(store, tmp_path / "zarr_out", mapping, video=_h264())
    assert summary.frames == 8
    data = _data(tmp_path / "zarr_out")
    root: Any = zarr.open_group(str(store), mode="r")
    np.testing.assert_array_equal(np.array(data["action"]), np.asarray(root["data/action"][:], np.float32))
    np.testing.assert_array_equal(np.array(data["observation.state"]), np.asarray(root["data/state"][:], np.float32))
    rlds = write_rlds(tmp_path / "toy_rlds" / "1.0.0", ((4,), (3,)), smooth=True)
    summary = openral_data.convert(str(rlds), tmp_path / "rlds_out", fps=5)
    assert (len(summary.episodes), summary.frames) == (2, 7)
    info = json.loads((tmp_path / "rlds_out" / "meta" / "info.json").read_text())
    assert info["fps"] == 5


def test_pipeline_convert_step_over_hdf5(tmp_path: Path) -> None:
    from openral_data.pipeline.runner import run_pipeline

    folder = tmp_path / "project"
    folder.mkdir()
    write_robomimic(folder / "demo.hdf5", (5,))
    spec = {"name": "from_hdf5", "steps": [
        {"id": "demos", "convert": {"source": "demo.hdf5", "fps": 25, "codec": "h264"}},
    ]}  # fmt: skip
    (folder / "pipeline.yaml").write_text(yaml.safe_dump(spec))
    report = run_pipeline(folder / "pipeline.yaml", tmp_path / "run")
    assert report.steps[0]["summary"]["dataset"]["frames"] == 5
    (out,) = {p.parent.parent for p in (tmp_path / "run" / "demos").rglob("meta/info.json")}
    assert json.loads((out / "meta" / "info.json").read_text())["fps"] == 25
    with h5py.File(folder / "demo.hdf5") as f:
        actions = f["data/demo_0/actions"][()]
    np.testing.assert_array_equal(np.array(_data(out)["action"]), actions.astype(np.float32))


def test_pipeline_convert_source_stays_in_the_pipeline_folder(tmp_path: Path) -> None:
    from openral_data.errors import OpenralError
    from openral_data.pipeline.schema import load_pipeline

    spec = {"name": "escape", "steps": [{"id": "demos", "convert": {"source": "../outside.hdf5"}}]}
    (tmp_path / "p.yaml").write_text(yaml.safe_dump(spec))
    with pytest.raises(OpenralError, match=r"steps\[0\]\.convert\.source"):
        load_pipeline(tmp_path / "p.yaml")


def _h264() -> VideoSettings:
    return VideoSettings(codec="h264")
