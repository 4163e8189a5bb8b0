"""Nothing derived from a file's contents reaches outside its root: a crafted journal, symlinked or FIFO control
files, a traversing camera key or path template, a pipeline robot id with ``../``. Each test puts a canary
outside the dataset (or the pipeline's workdir), runs the real CLI, and checks the canary is byte-identical, the
command refused in one ``error:`` line (exit 2) or, for plain `doctor`, reported an error finding and finished."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
from collections.abc import Iterator
from pathlib import Path

import pyarrow.parquet as pq
import pytest

from openral_data.formats.lerobot_v3 import layout
from tests.support.cli import run_cli
from tests.support.home import isolated_home
from tests.support.scenes import mock_scene, write_yaml

CANARY = b"canary: must never change \x00\xff"
FRONT = "observation.images.front"
DOCTOR_TIMEOUT_S = 120  # plain doctor on a FIFO control file used to block forever


@pytest.fixture(scope="module")
def recorded(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Path]:
    base = tmp_path_factory.mktemp("containment")
    scene = write_yaml(base / "scene.yaml", mock_scene(success_after=[4, 5], n_episodes=2))
    out = base / "ds"
    with isolated_home(base):
        done = run_cli("record", "--scene", str(scene), "--out", str(out), "--codec", "h264")
        assert done.returncode == 0, done.stderr
        yield out


@pytest.fixture
def case(recorded: Path, tmp_path: Path) -> tuple[Path, Path]:
    """(a fresh copy of the recording, a canary file outside it)."""
    root = tmp_path / "ds"
    shutil.copytree(recorded, root, symlinks=True)
    outside = tmp_path / "outside"
    outside.mkdir()
    canary = outside / "canary.bin"
    canary.write_bytes(CANARY)
    return root, canary


def _refused(done: subprocess.CompletedProcess[str], hint: str = "") -> None:
    assert done.returncode == 2, (done.stdout, done.stderr)
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), lines
    assert hint in lines[0]


def _untouched(canary: Path) -> None:
    assert canary.read_bytes() == CANARY
    assert sorted(p.name for p in canary.parent.iterdir()) == [canary.name]


def _info(root: Path, **changes: object) -> None:
    info = json.loads((root / layout.INFO_PATH).read_text())
    info.update(changes)
    (root / layout.INFO_PATH).write_text(json.dumps(info, indent=4))


# -- the commit journal -------------------------------------------------------------------------------------------
def _crafted_journal(root: Path, canary: Path) -> None:
    """Entries that move the canary out of its folder and over another file outside the dataset."""
    journal = root / layout.JOURNAL_PATH
    here = journal.parent
    renames = [[os.path.relpath(canary, here), os.path.relpath(canary.with_name("moved.bin"), here)]]
    journal.write_text(json.dumps({"renames": renames}))


def test_crafted_journal_plain_doctor_reports_it_not_repairable(case: tuple[Path, Path]) -> None:
    root, canary = case
    _crafted_journal(root, canary)
    done = run_cli("doctor", str(root))
    assert done.returncode == 1, done.stderr
    line = next(ln for ln in done.stdout.splitlines() if layout.JOURNAL_PATH in ln)
    assert line.startswith("error") and "[repairable]" not in line and "leads outside" in line
    assert "repairable with --repair" not in done.stdout
    _untouched(canary)


def test_crafted_journal_doctor_repair_refuses(case: tuple[Path, Path]) -> None:
    root, canary = case
    _crafted_journal(root, canary)
    _refused(run_cli("doctor", str(root), "--repair"), "renames[0]")
    _untouched(canary)
    assert (root / layout.JOURNAL_PATH).is_file()


def test_crafted_journal_record_resume_refuses(case: tuple[Path, Path], recorded: Path) -> None:
    root, canary = case
    _crafted_journal(root, canary)
    with isolated_home(recorded.parent):
        done = run_cli(
            "record",
            "--resume",
            "--out",
            str(root),
            "--n-episodes",
            "3",
            "--scene",
            str(recorded.parent / "scene.yaml"),
        )
    _refused(done, "renames[0]")
    _untouched(canary)


# -- control files -----------------------------------------------------------------------------------------------
def test_symlinked_lock_doctor_repair_refuses(case: tuple[Path, Path]) -> None:
    root, canary = case
    (root / layout.LOCK_PATH).symlink_to(canary)
    _refused(run_cli("doctor", str(root), "--repair"), "symbolic link")
    _untouched(canary)


def test_symlinked_state_dir_gets_no_quarantine_copies(case: tuple[Path, Path]) -> None:
    root, canary = case
    shutil.rmtree(root / layout.STATE_DIR)
    (root / layout.STATE_DIR).symlink_to(canary.parent, target_is_directory=True)
    (root / "data" / "chunk-000" / ".file-001.parquet.tmp").write_bytes(b"staged")  # something to quarantine
    _refused(run_cli("doctor", str(root), "--repair"), "not a real folder")
    _untouched(canary)
    done = run_cli("doctor", str(root))  # plain doctor names it and finishes
    assert done.returncode == 1, done.stderr
    assert any(ln.startswith("error") and layout.STATE_DIR in ln for ln in done.stdout.splitlines())
    _untouched(canary)


@pytest.mark.parametrize("rel", [layout.LOCK_PATH, layout.JOURNAL_PATH])
def test_fifo_control_file_plain_doctor_finishes(case: tuple[Path, Path], rel: str) -> None:
    root, canary = case
    os.mkfifo(root / rel)
    done = run_cli("doctor", str(root), timeout=DOCTOR_TIMEOUT_S)
    assert done.returncode == 1, done.stderr
    line = next(ln for ln in done.stdout.splitlines() if rel in ln)
    assert line.startswith("error") and "FIFO" in line and "[repairable]" not in line
    _refused(run_cli("doctor", str(root), "--repair", timeout=DOCTOR_TIMEOUT_S), "regular file")
    _untouched(canary)


# -- a camera key that traverses ---------------------------------------------------------------------------------
def _rename_camera(root: Path, old: str, new: str) -> None:
    """Rename a video feature everywhere a reader looks for it (info, episodes columns, stats, its folder)."""
    info = json.loads((root / layout.INFO_PATH).read_text())
    info["features"] = {new if k == old else k: v for k, v in info["features"].items()}
    (root / layout.INFO_PATH).write_text(json.dumps(info, indent=4))
    stats_path = root / layout.STATS_PATH
    stats = json.loads(stats_path.read_text())
    stats[new] = stats.pop(old)
    stats_path.write_text(json.dumps(stats))
    for path in layout.episodes_files(root):
        t = pq.read_table(path)
        names = [c.replace(f"/{old}/", f"/{new}/") for c in t.column_names]
        pq.write_table(t.rename_columns(names), path)
    src = root / "videos" / old
    dest = Path(os.path.normpath(root / "videos" / new))  # where a reader following the key finds the video
    dest.mkdir(parents=True, exist_ok=True)
    shutil.copytree(src, dest, dirs_exist_ok=True)


def test_traversing_camera_key_episodes_delete_writes_nothing_outside(case: tuple[Path, Path]) -> None:
    root, canary = case
    escape = f"../../outside/{FRONT}"  # ROOT/videos/<key> and NEW/videos/<key> both land in the canary's folder
    _rename_camera(root, FRONT, escape)
    new = root.parent / "new"
    before = _files_outside(root.parent, root, new)
    _refused(run_cli("episodes", "delete", str(root), "--episodes", "0", "--out", str(new)), "features")
    assert _files_outside(root.parent, root, new) == before and canary.read_bytes() == CANARY
    assert not new.exists() or not any(new.iterdir())
    done = run_cli("doctor", str(root))
    assert done.returncode == 1 and "is not a folder name" in done.stdout, done.stdout


def _files_outside(base: Path, *skip: Path) -> dict[str, bytes]:
    """Every file and folder below `base` but outside `skip`, with its bytes (folders: empty)."""
    out: dict[str, bytes] = {}
    for path in base.rglob("*"):
        if any(path == s or path.is_relative_to(s) for s in skip):
            continue
        out[str(path.relative_to(base))] = path.read_bytes() if path.is_file() else b""
    return out


# -- info.json path templates ------------------------------------------------------------------------------------
def _outside_template(root: Path, canary: Path) -> None:
    """data_path pointing at a real copy of the data file outside the dataset (a reader following it succeeds)."""
    chunk = canary.parent / "chunk-000"
    chunk.mkdir()
    shutil.copy2(root / "data" / "chunk-000" / "file-000.parquet", chunk / "file-000.parquet")
    _info(root, data_path="../outside/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet")


def _untouched_but_copy(canary: Path) -> None:
    assert canary.read_bytes() == CANARY
    assert sorted(p.name for p in canary.parent.iterdir()) == ["canary.bin", "chunk-000"]


def test_outside_template_convert_refuses(case: tuple[Path, Path]) -> None:
    root, canary = case
    _outside_template(root, canary)
    out = root.parent / "bags"
    _refused(run_cli("convert", str(root), str(out)), "data_path")
    _untouched_but_copy(canary)
    assert not out.exists() or not any(out.iterdir())


def test_outside_template_replay_refuses(case: tuple[Path, Path], recorded: Path) -> None:
    root, canary = case
    _outside_template(root, canary)
    with isolated_home(recorded.parent):
        done = run_cli("replay", str(root), "--out", str(root.parent / "results"))
    _refused(done, "data_path")
    _untouched_but_copy(canary)


def test_video_template_outside_is_refused_and_nonstandard_is_a_doctor_error(case: tuple[Path, Path]) -> None:
    root, canary = case
    _info(root, video_path="../outside/{video_key}/chunk-{chunk_index:03d}/file-{file_index:03d}.mp4")
    _refused(run_cli("convert", str(root), str(root.parent / "bags")), "video_path")
    _untouched(canary)
    _info(root, video_path="videos/{video_key}/c{chunk_index}/f{file_index}.mp4")  # inside, but not lerobot's
    done = run_cli("doctor", str(root))
    assert done.returncode == 1 and "is not lerobot's" in done.stdout, done.stdout


# -- pipeline ids -------------------------------------------------------------------------------------------------
def test_pipeline_robot_id_with_dotdot_is_refused_before_any_rmtree(tmp_path: Path) -> None:
    victim = tmp_path / "victim"
    victim.mkdir()
    canary = victim / "canary.bin"
    canary.write_bytes(CANARY)
    workdir = tmp_path / "run"
    # the folder the traversing item name passes through exists, so following it would reach `victim`
    (workdir / "rec" / "mock_pick--zero-mock--..").mkdir(parents=True)
    spec = write_yaml(
        tmp_path / "p.yaml",
        {
            "name": "escape",
            "steps": [
                {
                    "id": "rec",
                    "record": {
                        "scenes": ["mock_pick"],
                        "rskills": ["zero-mock"],
                        "robots": ["../../../victim"],
                        "seeds": {"count": 1},
                    },
                }
            ],
        },
    )
    with isolated_home(tmp_path):
        done = run_cli("pipeline", "run", str(spec), "--workdir", str(workdir))
    _refused(done, "robots")
    assert canary.read_bytes() == CANARY


def test_pipeline_garbage_marker_is_one_line(tmp_path: Path) -> None:
    workdir = tmp_path / "run"
    (workdir / "rec").mkdir(parents=True)
    (workdir / "rec" / ".done.json").write_bytes(b"\xff\xfe not json")
    spec = write_yaml(
        tmp_path / "p.yaml",
        {
            "name": "garbage",
            "steps": [
                {"id": "rec", "record": {"scenes": ["mock_pick"], "rskills": ["zero-mock"], "seeds": {"count": 1}}}
            ],
        },
    )
    with isolated_home(tmp_path):
        done = run_cli("pipeline", "run", str(spec), "--workdir", str(workdir))
    _refused(done, ".done.json")
