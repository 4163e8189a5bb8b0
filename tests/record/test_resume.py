"""`record --resume` and the writer lock: numbering, settings and statistics continue exactly; mismatches and a
second writer are refused with one line; crashes at exact points of an episode's commit lose nothing that
was reported finished, and lerobot 0.6.1 loads the killed dataset directly."""

from __future__ import annotations

import hashlib
import json
import re
import shutil
import signal
import subprocess
import sys
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pyarrow.parquet as pq
import pytest
import yaml

from openral_data.doctor import check

# ConfigError raises are matched by message on purpose: the file and field it names are the point
from openral_data.errors import ConfigError, DatasetBusy, DatasetError, OutputExists
from openral_data.formats.lerobot_v3 import layout
from openral_data.formats.lerobot_v3.lock import DatasetLock
from openral_data.formats.mcap.writer import finished_bags
from openral_data.record.options import RecordOptions
from openral_data.record.sim import record
from tests.support.cli import run_cli
from tests.support.home import REPO, isolated_home
from tests.support.lerobot import verify_mock_dataset
from tests.support.mcap import check_bag, chunk_compressions
from tests.support.scenes import mock_scene, write_yaml

LENGTHS = [5, 7, 4]  # the mock succeeds after these many steps, cycled over episodes
DRIVER = [sys.executable, "-m", "tests.support.record_driver"]  # run from REPO


def expected(n: int) -> list[int]:
    return [LENGTHS[e % len(LENGTHS)] for e in range(n)]


def drive(args: dict[str, object]) -> tuple[int, list[int]]:
    """Run tests/support/record_driver.py; return its exit status and the episodes record reported finished."""
    proc = subprocess.run(
        [*DRIVER, json.dumps(args)], cwd=REPO, capture_output=True, text=True, timeout=600, check=False
    )
    done = [int(line.split()[1]) for line in proc.stdout.splitlines() if line.startswith("finished ")]
    return proc.returncode, done


def snapshot(root: Path) -> dict[str, str]:
    return {
        str(p.relative_to(root)): hashlib.sha256(p.read_bytes()).hexdigest()
        for p in sorted(root.rglob("*"))
        if p.is_file() and layout.STATE_DIR not in p.relative_to(root).parts
    }


def seeds(root: Path) -> list[int]:
    rows = [r for f in sorted((root / "meta/episodes").glob("*/*.parquet")) for r in pq.read_table(f).to_pylist()]
    return [int(r["openral.seed"]) for r in rows]


def resumed(scene: Path, **given: Any) -> RecordOptions:
    """`record --resume --scene SCENE` with `given` (RecordOptions fields) on the command line: a recording made
    from a scene file names it again (record/recorded.py)."""
    explicit = frozenset({"scene", *given} - {"out"})
    return RecordOptions(scene=str(scene), resume=True, explicit=explicit, **given)


@pytest.fixture
def scene(tmp_path: Path, project: Path) -> Path:
    return write_yaml(tmp_path / "scene.yaml", mock_scene(success_after=LENGTHS, n_episodes=2))


@pytest.fixture(scope="module")
def home(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Path]:
    """A project home of this module's own (its rSkill files get edited), set as OPENRAL_DATA_HOME."""
    with isolated_home(tmp_path_factory.mktemp("resume_home")) as root:
        write_yaml(root / "scene.yaml", mock_scene(success_after=LENGTHS, n_episodes=2))
        yield root


@pytest.fixture(scope="module")
def one_episode(home: Path) -> Path:
    """A real one-episode recording (h264), made once; tests copy it."""
    out = home / "one"
    record(RecordOptions(scene=str(home / "scene.yaml"), out=out, n_episodes=1, codec="h264"))
    return out


def test_resume_continues_both_formats_exactly(tmp_path: Path, home: Path) -> None:
    out = tmp_path / "ds"
    opts = RecordOptions(scene=str(home / "scene.yaml"), out=out, codec="h264", formats=("lerobot", "mcap"))
    record(opts)
    stats_before = json.loads((out / layout.STATS_PATH).read_text())
    done = run_cli("record", "--resume", "--out", str(out), "--n-episodes", "4", "--scene", str(home / "scene.yaml"))
    assert done.returncode == 0, done.stderr
    assert "resumed at    episode 2" in done.stdout and "codec         h264" in done.stdout
    seen = verify_mock_dataset(out, "pyav")  # G channel = episode index: numbering continued
    assert seen["lengths"] == expected(4) and seeds(out) == [0, 1, 2, 3]
    assert check(out) == []
    info = json.loads((out / layout.INFO_PATH).read_text())
    assert info["total_episodes"] == 4 and info["total_frames"] == sum(expected(4))
    stats = json.loads((out / layout.STATS_PATH).read_text())
    assert stats["observation.state"]["count"] == [sum(expected(4))] != stats_before["observation.state"]["count"]
    assert stats["observation.images.front"]["count"] == [sum(expected(4))]  # exact histograms carried over
    assert stats["observation.state"]["max"][1] == 3.0  # state[1] = episode index of the last episode
    bags = finished_bags(out / "mcap")
    assert [b.name for b in bags] == [f"episode_{i:06d}" for i in range(4)]
    topics = check_bag(bags[3])
    start = json.loads(topics["/openral/episode"][0][1].data)
    assert start["episode"] == 3 and start["seed"] == 3
    states = [msg.position for _, msg in topics["/joint_states"]]
    assert len(states) == expected(4)[3] and all(s[1] == 3 for s in states)
    # nothing left to do: resuming again records nothing
    again = record(resumed(home / "scene.yaml", out=out, n_episodes=4))
    assert again.episodes == [] and again.resumed_at == 4


def test_resume_mcap_only(tmp_path: Path, home: Path) -> None:
    out = tmp_path / "bags"
    record(RecordOptions(scene=str(home / "scene.yaml"), out=out, n_episodes=1, formats=("mcap",)))
    (out / "mcap/.partial/episode_000001").mkdir(parents=True)  # a bag in flight when it was killed
    summary = record(resumed(home / "scene.yaml", out=out, n_episodes=3))
    assert summary.resumed_at == 1 and [e.index for e in summary.episodes] == [1, 2]
    bags = finished_bags(out / "mcap")
    assert [b.name for b in bags] == ["episode_000000", "episode_000001", "episode_000002"]
    assert not (out / "mcap/.partial").exists() and not (out / "meta").exists()
    with pytest.raises(ConfigError, match="formats: the dataset was recorded with mcap"):
        record(resumed(home / "scene.yaml", out=out, formats=("lerobot",)))


def test_resume_keeps_the_mcap_compression(tmp_path: Path, home: Path) -> None:
    out = tmp_path / "bags"
    scene = home / "scene.yaml"
    record(RecordOptions(scene=str(scene), out=out, n_episodes=1, formats=("mcap",), mcap_compression="lz4"))
    record(resumed(scene, out=out, n_episodes=2))
    assert [chunk_compressions(b) for b in finished_bags(out / "mcap")] == [{"lz4"}, {"lz4"}]
    with pytest.raises(ConfigError, match="mcap_compression: the dataset was recorded with lz4; --mcap-compression"):
        record(resumed(scene, out=out, mcap_compression="zstd"))
    # a recording made before chunks were compressed continues uncompressed
    settings = out / ".openral" / "record.json"
    doc = json.loads(settings.read_text())
    del doc["options"]["mcap_compression"]
    settings.write_text(json.dumps(doc))
    record(resumed(scene, out=out, n_episodes=3))
    assert chunk_compressions(finished_bags(out / "mcap")[2]) == {""}


def _edit(path: Path, fn: Callable[[dict[str, Any]], object]) -> None:
    data = yaml.safe_load(path.read_text())
    fn(data)
    path.write_text(yaml.safe_dump(data, sort_keys=False))


Edit = tuple[str, Callable[[dict[str, Any]], object]] | None
MISMATCHES: list[tuple[dict[str, Any], Edit, str]] = [
    ({"codec": "av1"}, None, "codec: the dataset was recorded with h264; --codec av1 differs"),
    ({"formats": ("lerobot", "mcap")}, None, "formats: the dataset was recorded with lerobot; --format lerobot,mcap"),
    ({"seed": 7}, None, "seed: the dataset was recorded with 0; --seed 7 differs"),
    ({"rskill": "zero-mock"}, None, "rskill: the dataset was recorded with"),
    ({}, ("scene.yaml", lambda d: d["scene"].update(fps=30)), "fps: the dataset has 20, this recording 30"),
    ({}, ("scene.yaml", lambda d: d["scene"]["cameras"].pop()), "cameras: the dataset has"),
    (
        {},
        ("rskills/random-mock/rskill.yaml", lambda d: d["state_contract"]["names"].__setitem__(0, "shoulder")),
        "state contract: the dataset has ['joint1'",
    ),
]


@pytest.mark.parametrize(("given", "edit", "message"), MISMATCHES, ids=[m[2].split(":")[0] for m in MISMATCHES])
def test_resume_refuses_mismatches(
    tmp_path: Path, home: Path, one_episode: Path, given: dict[str, Any], edit: Edit, message: str
) -> None:
    out = shutil.copytree(one_episode, tmp_path / "ds")
    if edit is not None and edit[0] == "scene.yaml":  # a recording from before scene_sha256, which would refuse
        settings = out / layout.RECORD_PATH  # the edited scene first (tests/trust/test_code.py)
        doc = json.loads(settings.read_text())
        del doc["options"]["scene_sha256"]
        settings.write_text(json.dumps(doc))
    before = snapshot(out)
    saved = {}
    if edit is not None:
        path = home / edit[0]
        saved[path] = path.read_text()
        _edit(path, edit[1])
    try:
        opts = resumed(home / "scene.yaml", out=out, n_episodes=3, **given)
        with pytest.raises(ConfigError) as err:
            record(opts)
    finally:
        for path, text in saved.items():
            path.write_text(text)
    assert message in str(err.value) and "\n" not in str(err.value)
    assert snapshot(out) == before and not (out / layout.LOCK_PATH).exists()


def test_cli_mismatch_is_one_line_and_fresh_record_into_a_dataset_is_refused(
    tmp_path: Path, home: Path, one_episode: Path
) -> None:
    out = shutil.copytree(one_episode, tmp_path / "ds")
    proc = run_cli("record", "--resume", "--out", str(out), "--codec", "av1", "--scene", str(home / "scene.yaml"))
    lines = [ln for ln in proc.stderr.splitlines() if ln.strip()]
    assert proc.returncode == 2 and len(lines) == 1, proc.stderr
    assert lines[0].startswith("error: ") and "codec: the dataset was recorded with h264" in lines[0]
    with pytest.raises(OutputExists, match="or --resume") as excinfo:  # the hint to resume is the point of the wording
        record(RecordOptions(scene=str(home / "scene.yaml"), out=out))
    assert excinfo.value.code == "output.exists"
    empty = tmp_path / "empty"
    empty.mkdir()
    with pytest.raises(DatasetError, match="nothing to resume") as excinfo:  # dataset.invalid has many causes
        record(RecordOptions(out=empty, resume=True))
    assert excinfo.value.code == "dataset.invalid"


def test_lock_refuses_a_second_writer(tmp_path: Path, home: Path, one_episode: Path) -> None:
    out = shutil.copytree(one_episode, tmp_path / "ds")
    opts = resumed(home / "scene.yaml", out=out, n_episodes=2)
    with DatasetLock(out, "another recording"), pytest.raises(DatasetBusy) as excinfo:
        record(opts)
    assert excinfo.value.code == "dataset.busy" and re.match(r"pid \d+, another recording", excinfo.value.holder)
    assert record(opts).resumed_at == 1


@pytest.mark.slow
def test_a_live_recording_holds_the_lock_and_a_killed_ones_is_stale(tmp_path: Path, project: Path) -> None:
    long = write_yaml(tmp_path / "long.yaml", mock_scene(success_after=10, max_steps=10, n_episodes=1000))
    out = tmp_path / "ds"
    proc = subprocess.Popen(
        [*DRIVER, json.dumps({"scene": str(long), "out": str(out), "n": 1000})],
        cwd=REPO,
        stdout=subprocess.PIPE,
        text=True,
    )
    try:
        assert proc.stdout is not None
        assert proc.stdout.readline().startswith("finished 0")
        second = run_cli("record", "--resume", "--out", str(out), "--n-episodes", "3")
        assert second.returncode == 2, second.stderr
        assert f"another writer holds this dataset (pid {proc.pid}, openral-data record" in second.stderr
    finally:
        proc.send_signal(signal.SIGKILL)
        proc.wait()
    assert (out / layout.LOCK_PATH).exists()  # left behind by the killed writer: stale, nobody holds it
    finished = json.loads((out / layout.INFO_PATH).read_text())["total_episodes"]
    again = run_cli("record", "--resume", "--out", str(out), "--n-episodes", str(finished + 1), "--scene", str(long))
    assert again.returncode == 0, again.stderr
    assert verify_mock_dataset(out, "pyav")["lengths"] == [10] * (finished + 1)


# (rename to die before, which one): each lands inside the commit of episode 2 (the third commit)
CRASH_POINTS = [
    pytest.param(("info.json", 3), 3, "writer.journal", id="info.json#3"),  # all renamed but info.json: finished
    pytest.param(  # staged and fsynced, journal not yet durable: the episode is discarded
        ("journal.json", 3), 2, "writer.staged", id="journal.json#3", marks=pytest.mark.slow
    ),
    pytest.param(  # journal durable, the episode's data file renamed, nothing else: finished on recovery
        ("file-002.parquet", 1), 3, "writer.journal", id="file-002.parquet#1", marks=pytest.mark.slow
    ),
]


@pytest.mark.parametrize(("die", "kept", "finding"), CRASH_POINTS)
def test_crash_inside_a_commit(tmp_path: Path, scene: Path, die: tuple[str, int], kept: int, finding: str) -> None:
    out = tmp_path / "ds"
    code, reported = drive({"scene": str(scene), "out": str(out), "n": 4, "die_at_rename": list(die)})
    assert code == 137 and reported == [0, 1]
    # lerobot's own loader on the killed dataset: the reported episodes, frame-exact
    seen = verify_mock_dataset(out, "pyav", uncounted_rows_ok=True)
    assert seen["lengths"] == expected(2)
    assert finding in {f.code for f in check(out)}
    done = run_cli("record", "--resume", "--out", str(out), "--n-episodes", "4", "--scene", str(scene))
    assert done.returncode == 0, done.stderr
    assert f"resumed at    episode {kept}" in done.stdout and "recovered" in done.stdout
    assert verify_mock_dataset(out, "pyav")["lengths"] == expected(4) and seeds(out) == [0, 1, 2, 3]
    assert check(out) == []
    assert not list(out.glob("[!.]*/**/*.tmp")) and not (out / layout.JOURNAL_PATH).exists()


@pytest.mark.slow
def test_killed_before_the_first_commit_resumes_from_zero(tmp_path: Path, scene: Path) -> None:
    out = tmp_path / "ds"
    code, reported = drive({"scene": str(scene), "out": str(out), "n": 2, "die_at_rename": ["journal.json", 1]})
    assert code == 137 and reported == [] and not (out / layout.INFO_PATH).exists()
    done = run_cli("record", "--resume", "--out", str(out), "--scene", str(scene))
    assert done.returncode == 0, done.stderr
    assert "resumed at    episode 0" in done.stdout
    assert verify_mock_dataset(out, "pyav")["lengths"] == expected(2) and check(out) == []
    assert any((out / layout.QUARANTINE_DIR).rglob("*.mp4"))  # the unfinished episode's video, set aside
