"""`formats.staging`: an output appears complete under its name or not at all; the staging folder of a dead
owner (SIGKILL) is removed by the next writer, a live owner's never is."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from openral_data.errors import OutputExists
from openral_data.formats.staging import Staging, clean_orphans, marker_of, staging_name

HOLD = """
import sys, time
from pathlib import Path
from openral_data.formats.staging import Staging
s = Staging(Path(sys.argv[1]), "test holder")
(s.open() / "data.bin").write_bytes(b"x" * 10)
print("ready", flush=True)
time.sleep(600)
"""


def _holder(out: Path) -> subprocess.Popen[str]:
    proc = subprocess.Popen([sys.executable, "-c", HOLD, str(out)], stdout=subprocess.PIPE, text=True)
    assert proc.stdout is not None and proc.stdout.readline().strip() == "ready"
    return proc


def test_publish_renames_complete_folder_and_leaves_nothing_hidden(tmp_path: Path) -> None:
    out = tmp_path / "ds"
    staged = Staging(out, "test")
    with staged as folder:
        assert folder == staging_name(out) and folder.name.startswith(".ds.partial-")
        assert marker_of(folder).read_text().startswith(f"pid {os.getpid()}, test, since ")
        (folder / "a.txt").write_text("a")
        assert not out.exists()
        staged.publish()
    assert (out / "a.txt").read_text() == "a"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["ds"]


def test_error_discards_staging_and_an_existing_output_is_refused(tmp_path: Path) -> None:
    out = tmp_path / "ds"
    with pytest.raises(RuntimeError), Staging(out, "test") as folder:
        (folder / "a.txt").write_text("a")
        raise RuntimeError("boom")
    assert list(tmp_path.iterdir()) == []
    staged = Staging(out, "test")
    with pytest.raises(OutputExists) as excinfo, staged as folder:
        (folder / "a.txt").write_text("new")
        out.mkdir()
        (out / "keep.txt").write_text("mine")  # something appeared meanwhile: never replaced
        staged.publish()
    assert excinfo.value.code == "output.exists"
    assert (out / "keep.txt").read_text() == "mine" and sorted(p.name for p in tmp_path.iterdir()) == ["ds"]


def test_dead_owner_is_cleaned_live_owner_kept(tmp_path: Path) -> None:
    live_out, dead_out = tmp_path / "live", tmp_path / "dead"
    live, dead = _holder(live_out), _holder(dead_out)
    try:
        dead.send_signal(signal.SIGKILL)
        dead.wait(timeout=30)
        dead_folder = dead_out.parent / f".dead.partial-{dead.pid}"
        live_folder = live_out.parent / f".live.partial-{live.pid}"
        assert (dead_folder / "data.bin").exists() and marker_of(dead_folder).exists()
        (tmp_path / ".user.partial-notes").mkdir()  # not a pid: not ours, never touched
        removed = clean_orphans(tmp_path)
        assert removed == [dead_folder]
        assert not dead_folder.exists() and not marker_of(dead_folder).exists()
        assert (live_folder / "data.bin").read_bytes() == b"x" * 10 and marker_of(live_folder).exists()
        assert (tmp_path / ".user.partial-notes").is_dir()
    finally:
        live.kill()
        live.wait(timeout=30)
    assert clean_orphans(tmp_path) == [live_out.parent / f".live.partial-{live.pid}"]


def test_markerless_folder_of_a_dead_pid_goes_of_a_live_pid_stays(tmp_path: Path) -> None:
    gone = subprocess.Popen([sys.executable, "-c", "pass"])
    gone.wait(timeout=30)
    (tmp_path / f".x.partial-{gone.pid}").mkdir()
    (tmp_path / f".y.partial-{os.getpid()}").mkdir()
    assert clean_orphans(tmp_path) == [tmp_path / f".x.partial-{gone.pid}"]
    assert (tmp_path / f".y.partial-{os.getpid()}").is_dir()
