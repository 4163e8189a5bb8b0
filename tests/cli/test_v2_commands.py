"""LeRobot v2.0 and v2.1 datasets read in place by every read-only command (`info`, `doctor --deep`, `stats`,
`tasks list`, `view --save`, `convert` to MCAP and back), and refused in one line naming `upgrade` by the edits.

The datasets are `tests.support.legacy_v2.write_v2`'s (written as lerobot 0.x wrote them) and, when present, the
real third-party v2.x fixtures of `tests.support.real_datasets`."""

from __future__ import annotations

import json
import shutil
import tempfile
from collections import Counter
from collections.abc import Callable
from pathlib import Path

import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from rerun.chunk import RrdReader

from tests.support.inproc import run_inproc
from tests.support.legacy_v2 import COLOUR_TOL, IMAGE_CAMERA, LENGTHS, TASKS, VIDEO_CAMERA, expected_episodes, write_v2
from tests.support.lerobot_written import digest
from tests.support.real_datasets import REAL, real_root
from tests.support.rrd import verify

VERSIONS = ["v2.0", "v2.1"]
DATA_0 = "data/chunk-000/episode_000000.parquet"
REAL_V2 = [name for name, d in REAL.items() if d.version in VERSIONS]


@pytest.fixture(scope="module", params=VERSIONS)
def v2(request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """v2.1 with a `dtype: image` camera beside the video one and null action names; v2.0 video only."""
    version = str(request.param)
    root = tmp_path_factory.mktemp(version) / "ds"
    return write_v2(root, version=version, image=version == "v2.1", names_null=version == "v2.1")


@pytest.fixture(scope="module", params=REAL_V2)
def real_v2(request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory) -> Path:
    src = real_root(str(request.param))
    if src is None:
        pytest.skip(f"real fixture {request.param} not present (tests/fixtures/lerobot/README.md)")
    dest = tmp_path_factory.mktemp("real") / str(request.param)
    shutil.copytree(src, dest)
    return dest


def _json(*args: str) -> dict[str, object]:
    proc = run_inproc(*args, "--json")
    assert proc.returncode == 0, proc.stderr
    doc: dict[str, object] = json.loads(proc.stdout)
    return doc


def test_info(v2: Path) -> None:
    version = json.loads((v2 / "meta/info.json").read_text())["codebase_version"]
    doc = _json("info", str(v2))
    assert (doc["episodes"], doc["frames"], doc["fps"]) == (3, sum(LENGTHS), 10)
    assert doc["tasks"] == list(TASKS) and doc["codebase_version"] == version
    assert VIDEO_CAMERA in doc["cameras"]  # type: ignore[operator]
    text = run_inproc("info", str(v2))
    assert text.returncode == 0 and f"LeRobot {version}" in text.stdout


def test_doctor_deep_healthy(v2: Path) -> None:
    doc = _json("doctor", str(v2), "--deep")
    assert doc["healthy"] is True and doc["findings"] == [] and doc["exit_code"] == 0


def test_doctor_finds_missing_files_and_refuses_repair(v2: Path, tmp_path: Path) -> None:
    root = shutil.copytree(v2, tmp_path / "ds")
    (root / "data/chunk-000/episode_000001.parquet").unlink()
    (root / f"videos/chunk-000/{VIDEO_CAMERA}/episode_000002.mp4").write_bytes(b"not a video")
    proc = run_inproc("doctor", str(root), "--deep", "--json")
    assert proc.returncode == 1, proc.stderr
    codes = {(f["code"], f["where"]) for f in json.loads(proc.stdout)["findings"]}
    assert ("v2.data.missing", "data/chunk-000/episode_000001.parquet") in codes
    assert ("v2.video.frames", f"videos/chunk-000/{VIDEO_CAMERA}/episode_000002.mp4") in codes
    before = sorted(p.relative_to(root) for p in root.rglob("*"))
    refused = run_inproc("doctor", str(root), "--repair")
    assert refused.returncode == 2 and "openral-data upgrade" in refused.stderr
    assert len(refused.stderr.strip().splitlines()) == 1
    assert sorted(p.relative_to(root) for p in root.rglob("*")) == before


def test_doctor_deep_sees_swapped_videos(tmp_path: Path) -> None:
    root = write_v2(tmp_path / "ds", version="v2.1", lengths=[4, 4])
    a, b = (root / f"videos/chunk-000/{VIDEO_CAMERA}/episode_00000{e}.mp4" for e in (0, 1))
    data = a.read_bytes()
    a.write_bytes(b.read_bytes())
    b.write_bytes(data)
    assert _json("doctor", str(root))["healthy"] is True  # same frame counts: only decoding tells
    proc = run_inproc("doctor", str(root), "--deep", "--json")
    assert proc.returncode == 1
    assert {f["code"] for f in json.loads(proc.stdout)["findings"]} == {"v2.video.content"}


def _rewrite_column(path: Path, name: str, values: list[object]) -> None:
    table = pq.read_table(path)
    column = pa.array(values, table.schema.field(name).type)
    pq.write_table(table.set_column(table.schema.get_field_index(name), name, column), path)


@pytest.mark.parametrize(
    ("damage", "code", "severity"),
    [
        (lambda r: _rewrite_column(r / DATA_0, "timestamp", [0.0, 0.5]), "v2.data.timestamps", "error"),
        (lambda r: _rewrite_column(r / DATA_0, "task_index", [0, 7]), "v2.data.task_index", "error"),
        (lambda r: _rewrite_column(r / DATA_0, "frame_index", [1, 0]), "v2.data.rows", "error"),
        (lambda r: _rewrite_column(r / DATA_0, "index", [10, 11]), "v2.data.index", "warning"),
        (lambda r: (r / "meta/episodes.jsonl").write_text("{oops\n"), "v2.meta", "error"),
        (lambda r: (r / "meta/episodes_stats.jsonl").unlink(), "v2.stats", "warning"),
    ],
)
def test_doctor_v2_findings(tmp_path: Path, damage: Callable[[Path], object], code: str, severity: str) -> None:
    root = write_v2(tmp_path / "ds", version="v2.1", lengths=[2, 3], video=False)
    damage(root)
    proc = run_inproc("doctor", str(root), "--json")
    assert proc.returncode == (1 if severity == "error" else 0), proc.stderr
    found = [(f["code"], f["severity"]) for f in json.loads(proc.stdout)["findings"]]
    scan = ("scan.timestamp_rate", "warning")  # timestamps off the grid: the scan also names the frames and step
    assert [f for f in found if f != scan or code != "v2.data.timestamps"] == [(code, severity)], found


def test_stats(v2: Path) -> None:
    proc = run_inproc("stats", str(v2))
    assert proc.returncode == 0, proc.stderr
    sql = "SELECT episode_index, count(*) AS n, max(frame_index) AS last, min(index) AS first FROM frames GROUP BY 1"
    proc = run_inproc("stats", str(v2), "--sql", sql + " ORDER BY 1", "--format", "json")
    assert proc.returncode == 0, proc.stderr
    rows = json.loads(proc.stdout)["sql"]
    starts = [sum(LENGTHS[:e]) for e in range(3)]
    assert rows == [{"episode_index": e, "n": n, "last": n - 1, "first": starts[e]} for e, n in enumerate(LENGTHS)]
    proc = run_inproc("stats", str(v2), "--sql", "SELECT episode_index, task, length FROM episodes ORDER BY 1")
    assert proc.returncode == 0 and TASKS[1] in proc.stdout


def test_tasks_list(v2: Path) -> None:
    doc = _json("tasks", "list", str(v2))
    assert doc["tasks"] == [
        {"task_index": 0, "task": TASKS[0], "episodes": [0, 2]},
        {"task_index": 1, "task": TASKS[1], "episodes": [1]},
    ]


def _rows(rrd: Path) -> Counter[str]:
    rows: Counter[str] = Counter()
    for chunk in RrdReader(rrd).stream():
        if not chunk.is_static:
            rows[chunk.entity_path] += chunk.num_rows
    return rows


def _scalars(rrd: Path, entity: str) -> list[float]:
    values: list[float] = []
    for chunk in RrdReader(rrd).stream():
        if chunk.entity_path == entity and not chunk.is_static:
            values += [v[0] for v in chunk.to_record_batch().column("Scalars:scalars").to_pylist()]
    return values


def test_view_save(v2: Path, tmp_path: Path) -> None:
    rrd = tmp_path / "ep.rrd"
    proc = run_inproc("view", str(v2), "--episode", "1", "--save", str(rrd))
    assert proc.returncode == 0, proc.stderr
    verify(rrd)
    rows = _rows(rrd)
    assert rows["/cameras/cam"] == LENGTHS[1] and rows["/state/x"] == LENGTHS[1]
    assert _scalars(rrd, "/state/x") == [f["state"][0] for f in expected_episodes()[1]]


@pytest.mark.slow  # two conversions and lerobot's loader (torch)
def test_convert_to_mcap_and_back(v2: Path, tmp_path: Path) -> None:
    """v2.x -> MCAP -> v3: lerobot 0.6.1 loads the v3 result with the v2 source's frames."""
    from tests.support.lerobot_written import loaded_episodes

    bags, out = tmp_path / "bags", tmp_path / "v3"
    proc = run_inproc("convert", str(v2), str(bags))
    assert proc.returncode == 0, proc.stderr
    proc = run_inproc("convert", str(bags), str(out), "--codec", "h264")
    assert proc.returncode == 0, proc.stderr
    image = IMAGE_CAMERA in json.loads((v2 / "meta/info.json").read_text())["features"]
    want = expected_episodes(video=True, image=image)
    got = loaded_episodes(out)
    assert [len(e) for e in got] == list(LENGTHS)
    for g_ep, w_ep in zip(got, want, strict=True):
        for g, w in zip(g_ep, w_ep, strict=True):
            assert g["task"] == w["task"]
            assert g["state"] == pytest.approx(w["state"]) and g["action"] == pytest.approx(w["action"])
            cam = g["cam"].transpose(1, 2, 0) * 255  # lerobot: CHW floats in [0, 1]
            assert abs(cam - w["cam"]).max() <= 2 * COLOUR_TOL
            if image:  # JPEG in the bags, h264 4:2:0 in v3: a gradient comes back close, not exact
                wrist = g["wrist"].transpose(1, 2, 0) * 255
                assert abs(wrist - w["wrist"]).mean() <= 6 and abs(wrist - w["wrist"]).max() <= 40


@pytest.mark.parametrize(
    "args",
    [
        ("tasks", "rename", "{ds}", "--from", TASKS[0], "--to", "x", "--out", "{out}"),
        ("episodes", "delete", "{ds}", "--episodes", "0", "--out", "{out}"),
    ],
)
def test_edits_write_v3_through_a_temporary_upgrade(
    v2: Path, tmp_path: Path, args: tuple[str, ...], monkeypatch: pytest.MonkeyPatch
) -> None:
    """Every edit of tests/compat/ runs on lerobot-written v2.x; here: the output is v3.0, the source unchanged,
    and no temporary folder is left."""
    out, before = tmp_path / "out", digest(v2)
    (tmp_path / "tmp").mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path / "tmp"))  # where the temporary upgrade goes
    proc = run_inproc(*(a.format(ds=v2, out=out) for a in args))
    assert proc.returncode == 0, proc.stderr
    assert _json("info", str(out))["codebase_version"] == "v3.0"
    assert digest(v2) == before and not list((tmp_path / "tmp").glob("openral-upgrade-*"))


def test_in_place_edit_and_push_refuse_v2(v2: Path, tmp_path: Path) -> None:
    before = digest(v2)
    proc = run_inproc("episodes", "delete", str(v2), "--episodes", "0", "--in-place")
    assert proc.returncode == 2 and len(proc.stderr.strip().splitlines()) == 1, proc.stderr
    assert "not edited in place" in proc.stderr and "openral-data upgrade" in proc.stderr
    proc = run_inproc("push", str(v2), "me/old", "--dry-run")
    assert proc.returncode == 2 and len(proc.stderr.strip().splitlines()) == 1, proc.stderr
    assert "openral-data upgrade" in proc.stderr
    assert digest(v2) == before


@pytest.mark.slow  # real AV1 videos decoded several times
def test_real_v2_read_only_commands(real_v2: Path, tmp_path: Path) -> None:
    """The real third-party v2.x fixtures: every read-only command takes them as they are."""
    meta = REAL[real_v2.name]
    doc = _json("info", str(real_v2))
    assert (doc["episodes"], doc["frames"], doc["codebase_version"]) == (meta.episodes, meta.frames, meta.version)
    proc = run_inproc("doctor", str(real_v2), "--deep", "--json")
    codes = {f["code"] for f in json.loads(proc.stdout)["findings"]}
    wallclock = any("wall-clock timestamps" in q for q in meta.quirks)  # off lerobot's frame grid: an error,
    # and the scan's warning naming the frames and the real step (0.0985 s at a declared 10 fps)
    expected = {"v2.data.timestamps", "scan.timestamp_rate"} if wallclock else set()
    assert codes - {"v2.data.index"} == expected, proc.stdout
    proc = run_inproc("stats", str(real_v2), "--sql", "SELECT count(*) AS n FROM frames", "--format", "json")
    assert proc.returncode == 0 and json.loads(proc.stdout)["sql"] == [{"n": meta.frames}], proc.stderr
    assert _json("tasks", "list", str(real_v2))["tasks"]
    first = json.loads((real_v2 / "meta/episodes.jsonl").read_text().splitlines()[0])["episode_index"]
    rrd = tmp_path / "real.rrd"
    assert run_inproc("view", str(real_v2), "--episode", str(first), "--save", str(rrd)).returncode == 0
    verify(rrd)
    proc = run_inproc("convert", str(real_v2), str(tmp_path / "bags"))
    assert proc.returncode == 0, proc.stderr
    proc = run_inproc("convert", str(tmp_path / "bags"), str(tmp_path / "v3"), "--codec", "h264")
    assert proc.returncode == 0, proc.stderr
    assert _json("info", str(tmp_path / "v3"))["frames"] == meta.frames
