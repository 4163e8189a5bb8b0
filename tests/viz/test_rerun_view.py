"""`view`: the .rrd passes `rerun rrd verify`, and reading it back shows the right entities and frame counts."""

from __future__ import annotations

import io
import json
import shutil
from collections import Counter
from collections.abc import Iterator
from pathlib import Path

import av
import pyarrow.parquet as pq
import pytest
from rerun.chunk import RrdReader

from openral_data.errors import OutputExists
from openral_data.viz.rerun_view import ViewOptions, run_view
from tests.support.cli import run_cli
from tests.support.metrics import A_SUCCESS_AFTER, MAX_STEPS, episodes_file, record_datasets
from tests.support.results import make_results
from tests.support.rrd import verify


@pytest.fixture(scope="module")
def dataset(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[Path, Path]]:
    base = tmp_path_factory.mktemp("view")
    a, _ = record_datasets(base)
    res, _ = make_results(a, base / "replay")
    yield a, res


def rows_by_entity(rrd: Path) -> tuple[Counter[str], Counter[str]]:
    temporal: Counter[str] = Counter()
    static: Counter[str] = Counter()
    for chunk in RrdReader(rrd).stream():
        (static if chunk.is_static else temporal)[chunk.entity_path] += chunk.num_rows
    return temporal, static


def column(rrd: Path, entity: str, name: str) -> list[object]:
    values: list[object] = []
    for chunk in RrdReader(rrd).stream():
        if chunk.entity_path == entity and not chunk.is_static:
            batch = chunk.to_record_batch()
            values += [v[0] if isinstance(v, list) else v for v in batch.column(name).to_pylist()]
    return values


def asset_video(rrd: Path, entity: str) -> bytes:
    for chunk in RrdReader(rrd).stream():
        if (
            chunk.entity_path == entity
            and chunk.is_static
            and "AssetVideo:blob" in chunk.to_record_batch().schema.names
        ):
            blob = chunk.to_record_batch().column("AssetVideo:blob").to_pylist()[0]
            return bytes(blob[0] if isinstance(blob[0], list) else blob)
    raise AssertionError(f"no AssetVideo at {entity}")


def test_view_episode_rrd(dataset: tuple[Path, Path], tmp_path: Path) -> None:
    a, res = dataset
    episode = 4
    n = min(A_SUCCESS_AFTER[episode], MAX_STEPS)
    rrd = tmp_path / "ep.rrd"
    proc = run_cli("view", str(a), "--episode", str(episode), "--save", str(rrd), "--results", str(res))
    assert proc.returncode == 0, proc.stderr
    assert f"{n} frames" in proc.stdout
    verify(rrd)
    temporal, static = rows_by_entity(rrd)
    info = json.loads((a / "meta/info.json").read_text())
    state_names = info["features"]["observation.state"]["names"]
    action_names = info["features"]["action"]["names"]
    expected = {f"/state/{s}" for s in state_names} | {f"/action/{s}" for s in action_names}
    expected |= {"/cameras/front", "/cameras/wrist", "/outcome/reward", "/outcome/success", "/outcome/done"}
    expected |= {"/replay/action_error", "/replay/divergence"}
    assert {e: temporal[e] for e in expected} == dict.fromkeys(expected, n)
    assert temporal["/events"] == 1
    assert {"/task", "/cameras/front", "/cameras/wrist"} <= set(static)
    # the episode sits in the middle of the shared mp4; the .rrd carries only its packets, remuxed to start at 0
    eps = pq.read_table(episodes_file(a)).to_pylist()
    assert eps[episode]["videos/observation.images.front/from_timestamp"] > 0
    stamps = column(rrd, "/cameras/front", "VideoFrameReference:timestamp")
    assert stamps == [round(k / 20 * 1e9) for k in range(n)]
    whole = (a / "videos/observation.images.front/chunk-000/file-000.mp4").stat().st_size
    clip = asset_video(rrd, "/cameras/front")
    assert len(clip) < whole / 3
    with av.open(io.BytesIO(clip), "r") as container:  # the mock paints frame t of episode e as (t, e, 128)
        colours = [f.to_ndarray(format="rgb24").reshape(-1, 3).mean(axis=0) for f in container.decode(video=0)]
    assert len(colours) == n
    for t, c in enumerate(colours):
        assert abs(c[0] - t) < 4 and abs(c[1] - episode) < 4 and abs(c[2] - 128) < 4, (t, c)
    state0 = column(rrd, "/state/joint1", "Scalars:scalars")
    assert state0 == [float(k) for k in range(n)]  # the mock's state is [t, e, 0, ...]
    state1 = column(rrd, "/state/joint2", "Scalars:scalars")
    assert state1 == [float(episode)] * n


def test_view_saves_when_there_is_no_display(
    dataset: tuple[Path, Path], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    a, _ = dataset
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    monkeypatch.delenv("OPENRAL_DATA_HOME", raising=False)
    monkeypatch.chdir(tmp_path)
    msg = run_view(ViewOptions(a, episode=2))
    rrd = tmp_path / "datasets" / f"{a.name}-episode-2.rrd"  # the project's outputs folder, not the cwd
    assert str(rrd.name) in msg and rrd.is_file()
    verify(rrd)
    temporal, _ = rows_by_entity(rrd)
    assert temporal["/action/gripper"] == min(A_SUCCESS_AFTER[2], MAX_STEPS)
    before = rrd.read_bytes()
    with pytest.raises(OutputExists) as excinfo:
        run_view(ViewOptions(a, episode=2))
    assert excinfo.value.code == "output.exists"
    assert rrd.read_bytes() == before


def test_view_errors(dataset: tuple[Path, Path], tmp_path: Path) -> None:
    a, _ = dataset
    proc = run_cli("view", str(a), "--episode", "99", "--save", str(tmp_path / "x.rrd"))
    assert proc.returncode == 2 and proc.stderr.startswith("error: --episode: 99 not in"), proc.stderr
    assert not (tmp_path / "x.rrd").exists()
    proc = run_cli("view", str(tmp_path), "--save", str(tmp_path / "y.rrd"))
    assert proc.returncode == 2 and "neither a LeRobot v3 dataset" in proc.stderr


def test_lerobot_layout_view(dataset: tuple[Path, Path], tmp_path: Path) -> None:
    """Without our episode columns the success label comes from next.success."""
    a, _ = dataset
    plain = tmp_path / "plain"
    shutil.copytree(a, plain)
    ep = episodes_file(plain)
    t = pq.read_table(ep)
    pq.write_table(t.drop_columns([c for c in t.column_names if c.startswith("openral.")]), ep)
    rrd = tmp_path / "plain.rrd"
    run_view(ViewOptions(plain, episode=2, save=rrd))
    verify(rrd)
    texts = column(rrd, "/events", "TextLog:text")
    assert texts == ["episode 2 done: failure"]


def test_view_mcap(tmp_path: Path) -> None:
    """MCAP goes through rerun's own MCAP loader; every message of the channel arrives."""
    from mcap.writer import Writer

    path = tmp_path / "run.mcap"
    with path.open("wb") as f:
        writer = Writer(f)
        writer.start()
        schema = json.dumps({"type": "object", "properties": {"x": {"type": "number"}}}).encode()
        sid = writer.register_schema(name="State", encoding="jsonschema", data=schema)
        cid = writer.register_channel(topic="/robot/state", message_encoding="json", schema_id=sid)
        for i in range(25):
            t = 1_000_000_000 + i * 50_000_000
            writer.add_message(channel_id=cid, log_time=t, publish_time=t, data=json.dumps({"x": i / 10}).encode())
        writer.finish()
    rrd = tmp_path / "run.rrd"
    proc = run_cli("view", str(path), "--save", str(rrd))
    assert proc.returncode == 0, proc.stderr
    verify(rrd)
    temporal, _ = rows_by_entity(rrd)
    assert temporal["/robot/state"] == 25


def test_view_rosbag2_folder(tmp_path: Path) -> None:
    """A rosbag2 folder (metadata.yaml + one .mcap, as rosbags writes it) is viewed as the .mcap inside."""
    from tests.support.bags import write_ros2

    bag = write_ros2(tmp_path / "bag", "mcap", duration_ms=300)
    (inner,) = bag.glob("*.mcap")
    by_folder, by_file = tmp_path / "folder.rrd", tmp_path / "file.rrd"
    proc = run_cli("view", str(bag), "--save", str(by_folder))
    assert proc.returncode == 0, proc.stderr
    assert run_cli("view", str(inner), "--save", str(by_file)).returncode == 0
    verify(by_folder)
    temporal, _ = rows_by_entity(by_folder)
    assert temporal == rows_by_entity(by_file)[0]
    assert temporal["/joint_states"] == 30  # 100 Hz for 300 ms: every message arrived


def test_view_rosbag2_folder_without_one_mcap(tmp_path: Path) -> None:
    from tests.support.bags import write_ros2

    bag = write_ros2(tmp_path / "bag", "sqlite3", duration_ms=100)
    rrd = tmp_path / "x.rrd"
    proc = run_cli("view", str(bag), "--save", str(rrd))
    assert proc.returncode == 2
    assert proc.stderr.strip() == (
        f"error: {bag}: a rosbag2 folder: view needs exactly one .mcap file in it (found: none); pass the .mcap to show"
    ), proc.stderr
    assert not rrd.exists()
