"""A full or failing disk ends a recording with one line naming the problem and the episodes kept; what was
committed before stays loadable by lerobot 0.6.1 without repair, and `record --resume` (after freeing space)
completes the requested count. Proved two ways, for the LeRobot sink, the MCAP sink and both at once:

* fault injection (tests/support/faults.py): every write, fsync, rename, join and bag write from the start of
  the last episode to the end of the run (its commit and `close()`) fails in turn, the disk staying full;
* a real full disk: a small tmpfs, filled up by a recording through the CLI.

Failures that leave byte-for-byte the same files (e.g. any failure before the commit journal: everything
staged is removed again) are loaded and resumed once; every failing call still has its one line checked.
"""

from __future__ import annotations

import errno
import os
import re
import shutil
import subprocess
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from rosbags.highlevel import AnyReader

from openral_data.doctor import check
from openral_data.errors import DiskError, OpenralError
from openral_data.formats.lerobot_v3 import layout
from openral_data.formats.mcap.writer import finished_bags
from openral_data.record.options import RecordOptions
from openral_data.record.sim import record
from openral_data.runtime.sinks import OutputFormat
from openral_data.types import EpisodeRecord
from tests.support.cli import run_cli
from tests.support.faults import Faults, inject
from tests.support.home import isolated_home
from tests.support.lerobot import verify_mock_dataset
from tests.support.scenes import mock_scene, write_yaml

LENGTHS = [3, 2, 4]
FORMATS: dict[str, tuple[OutputFormat, ...]] = {"lerobot": ("lerobot",), "mcap": ("mcap",), "both": ("lerobot", "mcap")}
KEPT = re.compile(r"; (?:no episode is|episode 0 is|episodes 0-(\d+) are) kept \(free space, then record --resume")


def expected(n: int) -> list[int]:
    return [LENGTHS[e % len(LENGTHS)] for e in range(n)]


def kept_in(line: str) -> int:
    """How many episodes the one line says are kept."""
    found = KEPT.search(line)
    assert found, line
    if "no episode" in found.group(0):
        return 0
    return int(found.group(1)) + 1 if found.group(1) else 1


@pytest.fixture(scope="module")
def home(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Path]:
    """A project home with a mock scene of one tiny camera (small, fast commits that still place a video)."""
    with isolated_home(tmp_path_factory.mktemp("disk_home")) as root:
        scene = mock_scene(cameras=[("front", 16, 16)], success_after=LENGTHS, n_episodes=2, max_steps=20)
        write_yaml(root / "scene.yaml", scene)
        yield root


def resume(out: Path, n: int, home: Path, faults: Faults | None = None) -> OpenralError | None:
    """`record --resume --out OUT --n-episodes N --scene HOME/scene.yaml` (the scene file `out` was recorded
    from, named again) in this process; `faults` armed once the episode loop starts."""

    def progress(rec: EpisodeRecord | None, frames: int, total: int) -> None:
        if rec is None and faults is not None:
            faults.armed = True

    scene = str(home / "scene.yaml")
    opts = RecordOptions(scene=scene, out=out, n_episodes=n, resume=True, explicit=frozenset({"n_episodes", "scene"}))
    try:
        record(opts, progress)
    except OpenralError as exc:
        return exc
    return None


def bag_episodes(out: Path) -> list[tuple[int, int]]:
    """(episode index carried in the state, length) of every finished bag, read back with rosbags."""
    found = []
    for bag in finished_bags(out / "mcap"):
        with AnyReader([bag]) as reader:
            conns = [c for c in reader.connections if c.topic == "/joint_states"]
            msgs: list[Any] = [reader.deserialize(raw, c.msgtype) for c, _, raw in reader.messages(conns)]
        states = [m.position for m in msgs]
        assert {int(s[1]) for s in states} == {int(bag.name.split("_")[1])}, bag
        found.append((int(states[0][1]), len(states)))
    return found


def check_kept(out: Path, formats: tuple[str, ...], kept: int, committed: bool, joining: bool = False) -> None:
    """What a reader sees right after the failure, without any repair. `joining`: it failed inside close()'s
    join of the per-episode files, which may leave copies of counted rows trailing in meta/episodes (beyond
    info.json's total, like a commit's uncounted row; the items are unaffected)."""
    if "lerobot" in formats:
        seen = verify_mock_dataset(out, "pyav", uncounted_rows_ok=committed or joining)
        # a commit past its journal may be part-renamed: lerobot sees it once info.json (renamed last) counts it
        assert seen["lengths"] in ([expected(kept)] + ([expected(kept - 1)] if committed else [])), seen
    if "mcap" in formats:
        # MCAP commits first: with both sinks, LeRobot may have failed after that episode's bag was done
        counts = (kept, kept + 1) if "lerobot" in formats else (kept,)
        assert bag_episodes(out) in [list(enumerate(expected(n))) for n in counts]


def check_complete(out: Path, formats: tuple[str, ...], n: int) -> None:
    if "lerobot" in formats:
        assert verify_mock_dataset(out, "pyav")["lengths"] == expected(n)
        assert check(out) == []
        assert not (out / layout.JOURNAL_PATH).exists() and not list(out.glob("[!.]*/**/.*.tmp"))
    if "mcap" in formats:
        assert bag_episodes(out) == list(enumerate(expected(n)))
        assert not (out / "mcap/.partial").exists()


def files_of(out: Path) -> tuple[tuple[str, int], ...]:
    """The files a failure left (names and sizes; the lock and the quarantine aside): equal means same state."""
    skip = {layout.LOCK_PATH, layout.QUARANTINE_DIR}
    return tuple(
        (str(p.relative_to(out)), p.stat().st_size)
        for p in sorted(out.rglob("*"))
        if p.is_file() and not any(str(p.relative_to(out)).startswith(str(s)) for s in skip)
    )


@pytest.mark.parametrize("name", ["lerobot", "mcap", pytest.param("both", marks=pytest.mark.slow)])
def test_every_failing_write_of_the_last_episode_and_close(tmp_path: Path, home: Path, name: str) -> None:
    formats = FORMATS[name]
    first = tmp_path / "first"  # episode 0, committed; each case continues it with episode 1
    record(RecordOptions(scene=str(home / "scene.yaml"), out=first, n_episodes=1, codec="h264", formats=formats))
    counted = Faults()
    clean = tmp_path / "clean"
    shutil.copytree(first, clean)
    with inject(counted):
        assert resume(clean, 2, home, counted) is None
    calls = counted.calls
    assert len(calls) >= (12 if name == "mcap" else 40), calls  # every write, fsync and rename of the commit
    check_complete(clean, formats, 2)
    seen: dict[tuple[tuple[str, int], ...], int] = {}
    for n in range(1, len(calls) + 1):
        out = tmp_path / f"fail{n}"
        shutil.copytree(first, out)
        faults = Faults(fail_at=n)
        with inject(faults):
            err = resume(out, 2, home, faults)
        where = f"call {n} ({calls[n - 1]})"
        assert isinstance(err, DiskError) and err.code == "write.disk", (where, err)
        line = str(err)
        assert "\n" not in line and line.startswith(f"{out}: no space left on device while "), (where, line)
        kept = kept_in(line)
        assert kept in (1, 2), (where, line)
        state = files_of(out)
        if seen.get(state) == kept:  # the same files as a failure already checked below
            shutil.rmtree(out)
            continue
        seen[state] = kept
        check_kept(out, formats, kept, committed=err.committed, joining=err.doing.startswith("joining"))
        assert resume(out, 2, home) is None, where
        check_complete(out, formats, 2)
        shutil.rmtree(out)
    assert len(seen) > 1


@pytest.mark.parametrize("code", [errno.EIO, errno.EROFS, errno.EDQUOT])
def test_each_disk_errno_is_named(tmp_path: Path, home: Path, code: int) -> None:
    """One failing call (the episode's data file staged, then every later call fails): the line names the errno."""
    out = tmp_path / "ds"
    record(RecordOptions(scene=str(home / "scene.yaml"), out=out, n_episodes=1, codec="h264"))
    before = {p: p.read_bytes() for p in sorted((out / "meta").rglob("*")) if p.is_file()}
    faults = Faults(fail_at=4, errno=code)
    with inject(faults):
        err = resume(out, 3, home, faults)
    assert isinstance(err, DiskError) and err.code == "write.disk"
    what = os.strerror(code)
    assert str(err) == (
        f"{out}: {what[0].lower()}{what[1:]} while committing episode 1; "
        "episode 0 is kept (free space, then record --resume)"
    )
    assert {p: p.read_bytes() for p in sorted((out / "meta").rglob("*")) if p.is_file()} == before
    assert resume(out, 3, home) is None
    check_complete(out, ("lerobot",), 3)


def test_a_one_off_error_inside_the_renames_is_finished_by_resume(tmp_path: Path, home: Path) -> None:
    """EIO once on a rename after the journal: the rest of the run may write again, yet nothing more is written,
    the line says the episode is finished by the resume, and it is."""
    out = tmp_path / "ds"
    record(RecordOptions(scene=str(home / "scene.yaml"), out=out, n_episodes=1, codec="h264"))
    counted = Faults()
    probe = tmp_path / "probe"
    shutil.copytree(out, probe)
    with inject(counted):
        assert resume(probe, 2, home, counted) is None
    stats = counted.calls.index("replace stats.json") + 1
    faults = Faults(fail_at=stats, errno=errno.EIO, persist=False)
    with inject(faults):
        err = resume(out, 2, home, faults)
    assert isinstance(err, DiskError) and err.committed
    assert str(err) == (
        f"{out}: input/output error while committing episode 1; "
        "episodes 0-1 are kept (free space, then record --resume finishes episode 1's commit)"
    )
    assert len(faults.calls) == stats  # failed: close() wrote nothing more
    assert (out / layout.JOURNAL_PATH).is_file()
    assert verify_mock_dataset(out, "pyav", uncounted_rows_ok=True)["lengths"] == expected(1)
    assert resume(out, 3, home) is None
    check_complete(out, ("lerobot",), 3)


# -- a real full disk ------------------------------------------------------------------------------------------


@pytest.fixture
def small_disk(tmp_path: Path) -> Iterator[Path]:
    """A 2 MiB tmpfs (root only; skipped where mounting is not permitted), always unmounted afterwards."""
    mnt = tmp_path / "disk"
    mnt.mkdir()
    if os.geteuid() != 0:
        pytest.skip("mounting a tmpfs needs root")
    done = subprocess.run(
        ["mount", "-t", "tmpfs", "-o", "size=2M", "tmpfs", str(mnt)], capture_output=True, check=False
    )
    if done.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs here: {done.stderr.decode(errors='replace').strip()}")
    try:
        yield mnt
    finally:
        subprocess.run(["umount", "-l", str(mnt)], check=False)


@pytest.mark.slow
def test_a_full_tmpfs(small_disk: Path, home: Path) -> None:
    filler = small_disk / "filler"
    st = os.statvfs(small_disk)
    filler.write_bytes(b"\0" * (st.f_bavail * st.f_frsize - 400 * 1024))  # leave room for a few episodes
    out = small_disk / "ds"
    scene = home / "scene_long.yaml"
    write_yaml(scene, mock_scene(cameras=[("front", 64, 48)], success_after=[30, 20, 40], n_episodes=12, max_steps=60))
    full = run_cli("record", "--scene", str(scene), "--out", str(out), "--codec", "h264", "--format", "lerobot,mcap")
    assert full.returncode == 2, full.stderr
    line = full.stderr.strip()
    assert "\n" not in line and line.startswith(f"error: {out}: no space left on device while "), line
    kept = kept_in(line)
    assert 0 < kept < 12, line
    lengths = [[30, 20, 40][e % 3] for e in range(12)]
    seen = verify_mock_dataset(out, "pyav", uncounted_rows_ok=True)  # no repair first
    assert seen["lengths"] in (lengths[:kept], lengths[: kept - 1]), (line, seen)
    filler.unlink()  # free space
    done = run_cli("record", "--resume", "--out", str(out), "--scene", str(scene))
    assert done.returncode == 0, done.stderr
    assert verify_mock_dataset(out, "pyav")["lengths"] == lengths
    assert [n for _, n in bag_episodes(out)] == lengths
    assert check(out) == []


def test_a_stop_that_came_before_the_loop_started_stops_it_at_the_first_boundary() -> None:
    """A `--workers` worker's SIGTERM while its scene was still being built (before the episode loop installed its
    handlers) is remembered in EARLY_STOP; the loop's StopRequest starts stopped instead of recording the share."""
    from openral_data.record.session import EARLY_STOP, StopRequest

    EARLY_STOP.set()
    try:
        stop = StopRequest()
        try:
            with pytest.raises(KeyboardInterrupt):
                stop.check()
        finally:
            stop.restore()
    finally:
        EARLY_STOP.clear()
    stop = StopRequest()
    stop.check()  # without one, nothing is requested
    stop.restore()
