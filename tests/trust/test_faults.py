"""Faults that used to end in a traceback (#29, class 7): a Ctrl-C while the command line is still importing its
modules, a full disk while taking the writer lock, EIO on the last fsync of a publish, and a `--plot` / `--save`
into a read-only folder. Each is one `error:` line and exit 2 (Ctrl-C: exit 130), nothing written lost."""

from __future__ import annotations

import errno
import os
import shutil
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from openral_data.formats import atomic
from tests.support.cli import run_cli
from tests.support.faults import Faults, inject
from tests.support.inproc import Run, run_inproc
from tests.support.interrupt import snapshot
from tests.support.readonly import read_only_view, small_disk
from tests.support.recorded import record_small

TASK = "pick up the mock cube"  # the mock scene's task


@pytest.fixture(scope="module")
def recorded(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return record_small(tmp_path_factory.mktemp("faults_ds"))


@pytest.fixture
def dataset(recorded: Path, tmp_path: Path) -> Path:
    shutil.copytree(recorded, tmp_path / "ds")
    return tmp_path / "ds"


def _one_error_line(run: Run, *parts: str) -> None:
    assert run.returncode == 2, run.stderr
    assert "Traceback" not in run.stderr, run.stderr
    assert run.stderr.count("\n") == 1 and run.stderr.startswith("error: "), run.stderr
    for part in parts:
        assert part in run.stderr


@pytest.mark.parametrize(
    "args",
    [("tasks", "rename", "{ds}", "--from", TASK, "--to", "new", "--in-place"), ("doctor", "{ds}", "--repair")],
    ids=["in-place-edit", "doctor-repair"],
)
def test_full_disk_while_taking_the_lock(dataset: Path, args: tuple[str, ...], monkeypatch: pytest.MonkeyPatch) -> None:
    """ENOSPC creating `.openral/lock` (`atomic.open_control` with O_CREAT): one line, the dataset unchanged."""
    real = atomic.open_control

    def full(path: Path, flags: int = os.O_RDONLY, mode: int = 0o644) -> int:
        if path.name == "lock" and flags & os.O_CREAT:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(path))
        return real(path, flags, mode)

    before = snapshot(dataset)
    monkeypatch.setattr(atomic, "open_control", full)
    run = run_inproc(*(a.format(ds=dataset) for a in args))
    _one_error_line(run, str(dataset), "no space left on device while taking its writer lock")
    assert snapshot(dataset) == before


def _edit(ds: Path, where: str) -> list[str]:
    output = ["--in-place"] if where == "in-place" else ["--out", str(ds.parent / "out")]
    return ["tasks", "rename", str(ds), "--from", TASK, "--to", "new", *output]


def _calls(ds: Path, where: str) -> list[str]:
    """The file-system calls of a clean edit (on a throw-away copy of `ds`)."""
    probe = ds.parent / "probe" / ds.name
    shutil.copytree(ds, probe)
    faults = Faults(armed=True)
    with inject(faults):
        assert run_inproc(*_edit(probe, where)).returncode == 0
    return faults.calls


def _fail_at(ds: Path, where: str, fail_at: int) -> Run:
    with inject(Faults(fail_at=fail_at, errno=errno.EIO, persist=False, armed=True)):
        return run_inproc(*_edit(ds, where))


@pytest.mark.parametrize("where", ["out", "in-place"])
def test_eio_on_the_last_fsync_before_the_publish(dataset: Path, where: str) -> None:
    """EIO fsyncing the finished output right before it is renamed into place: one line, nothing published, the
    source unchanged (the fault checkers of tests/formats cover the writes before)."""
    calls = _calls(dataset, where)
    rename = max(i for i, c in enumerate(calls) if c == f"replace {'out' if where == 'out' else dataset.name}")
    last_fsync = max(i for i, c in enumerate(calls[:rename]) if c == "fsync")
    before = snapshot(dataset)
    run = _fail_at(dataset, where, last_fsync + 1)
    _one_error_line(run, "input/output error while")
    assert snapshot(dataset) == before
    assert not (dataset.parent / "out").exists()


def test_eio_renaming_the_edit_into_place_keeps_the_dataset(dataset: Path) -> None:
    """`--in-place`: EIO on the rename of the edited copy onto the dataset's name (its original already moved
    aside): the original is put back under its name, unchanged."""
    calls = _calls(dataset, "in-place")
    rename = calls.index(f"replace {dataset.name}")
    before = snapshot(dataset)
    run = _fail_at(dataset, "in-place", rename + 1)
    _one_error_line(run, str(dataset), "input/output error while replacing it")
    assert snapshot(dataset) == before
    assert not [p.name for p in dataset.parent.iterdir() if ".replaced-" in p.name]


@pytest.mark.parametrize(
    "args",
    [("stats", "{ds}", "--plot", "{ro}/plot.png"), ("view", "{ds}", "--save", "{ro}/sub/x.rrd")],
    ids=["stats-plot", "view-save"],
)
def test_output_file_into_a_read_only_folder(recorded: Path, tmp_path: Path, args: tuple[str, ...]) -> None:
    (tmp_path / "src").mkdir()
    with read_only_view(tmp_path / "src", tmp_path / "ro") as ro:
        run = run_inproc(*(a.format(ds=recorded, ro=ro) for a in args))
    _one_error_line(run, "cannot write into", "read-only or no permission")
    assert not any((tmp_path / "src").iterdir())


ENTRY_POINTS = {
    "python -m": [sys.executable, "-m", "openral_data.cli"],
    "console script": [str(Path(sys.executable).with_name("openral-data"))],
}


@pytest.mark.parametrize("entry", list(ENTRY_POINTS), ids=list(ENTRY_POINTS))
def test_ctrl_c_while_importing_exits_130_without_traceback(entry: str, tmp_path: Path) -> None:
    """SIGINT right after `typer` is imported, while the command modules are still loading (`-X importtime`
    reports each finished import on stderr, so the signal lands inside the import window, not by timing)."""
    cmd = ENTRY_POINTS[entry]
    if not Path(cmd[0]).exists():
        pytest.skip(f"{cmd[0]} is not installed")
    env = {**os.environ, "PYTHONPROFILEIMPORTTIME": "1"}
    proc = subprocess.Popen(
        [*cmd, "info", str(tmp_path / "missing")], stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env, text=True
    )
    assert proc.stderr is not None
    seen: list[str] = []
    for line in proc.stderr:
        seen.append(line)
        if line.split("|")[-1].strip() == "typer":
            proc.send_signal(signal.SIGINT)
            break
    _, rest = proc.communicate(timeout=60)
    stderr = "".join(seen) + rest
    assert seen and seen[-1].split("|")[-1].strip() == "typer", "typer's import was never reported"
    assert "Traceback" not in stderr, stderr[-2000:]
    assert proc.returncode == 130, stderr[-3000:]


def test_view_save_where_no_file_can_be_made_is_one_line(recorded: Path) -> None:
    """A folder that passes the output checks but refuses new files (/proc): one line naming the output, not an
    OSError traceback from opening the .rrd."""
    out = Path("/proc") / f"openral-view-{os.getpid()}.rrd"
    run = run_inproc("view", str(recorded), "--save", str(out))
    _one_error_line(run, f"{out}: cannot write the recording:")


def test_view_save_onto_a_full_disk_is_one_line(recorded: Path, tmp_path: Path) -> None:
    """A full disk while the .rrd is written: one line, nothing left behind. (rerun's own file sink stopped with a
    RuntimeError traceback and its own log lines, or hung in flush; viz/rrd_file.py writes the file instead.) In a
    subprocess: rerun reads RUST_LOG when it is first imported."""
    with small_disk(tmp_path / "full") as full:
        run = run_cli("view", str(recorded), "--save", str(full / "v.rrd"))
        assert "Traceback" not in run.stderr, run.stderr
        lines = [ln for ln in run.stderr.splitlines() if ln.strip()]
        assert run.returncode == 2 and len(lines) == 1, run.stderr
        assert lines[0].startswith(f"error: {full / 'v.rrd'}: cannot write the recording"), lines[0]
        assert not list(full.iterdir())  # neither the .rrd nor its hidden partial copy
