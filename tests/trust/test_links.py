"""Symlinks in a dataset's folders that lead out of it (#29 classes 2-4): `doctor --repair` and `record --resume`
refuse the dataset before touching anything, every edit, `view` and `stats recompute` refuses before reading an
outside file, and a folder outside stays byte-identical. A link that stays inside the dataset still works; an
`--in-place` edit of a DATASET given as a symlink edits the real folder and leaves the link."""

from __future__ import annotations

import json
import shutil
from collections.abc import Iterator
from pathlib import Path

import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from openral_data.formats.lerobot_v3 import layout
from tests.support.home import isolated_home
from tests.support.inproc import Run, run_inproc

FRONT = "observation.images.front"
WRIST = "observation.images.wrist"
MP4 = f"videos/{FRONT}/chunk-000/file-000.mp4"


@pytest.fixture(scope="module")
def recorded(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Path]:
    """Two short mock episodes, as LeRobot and MCAP; the project home stays set for the module."""
    base = tmp_path_factory.mktemp("links")
    out = base / "ds"
    with isolated_home(base):
        args = ("--n-episodes", "2", "--max-steps", "3", "--codec", "h264", "--format", "lerobot,mcap")
        done = run_inproc("record", *args, "--out", str(out))
        assert done.returncode == 0, done.stderr
        yield out


@pytest.fixture
def root(recorded: Path, tmp_path: Path) -> Path:
    """A fresh copy of the recording; `tmp_path / "outside"` is where links lead out to."""
    shutil.copytree(recorded, tmp_path / "ds", symlinks=True)
    (tmp_path / "outside").mkdir()
    return tmp_path / "ds"


def _link_out(root: Path, rel: str) -> Path:
    """Move `root/rel` (a file or folder) outside the dataset and leave a symlink to it in its place."""
    target = root.parent / "outside" / rel.replace("/", "--")
    (root / rel).rename(target)
    (root / rel).symlink_to(target, target_is_directory=target.is_dir())
    return target


def _snapshot(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


def _refused(done: Run, hint: str) -> None:
    assert done.returncode == 2, (done.stdout, done.stderr)
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), lines
    assert hint in lines[0], lines[0]


# -- doctor --repair (class 2) -------------------------------------------------------------------------------------
def test_repair_refuses_a_camera_folder_leading_out(root: Path) -> None:
    outside = _link_out(root, f"videos/{FRONT}")
    shutil.copy2(outside / "chunk-000" / "file-000.mp4", outside / "chunk-000" / "file-007.mp4")  # an "orphan"
    before = _snapshot(root.parent / "outside")
    plain = run_inproc("doctor", str(root))
    assert plain.returncode == 1
    assert any(ln.startswith(f"error   videos/{FRONT}: a symbolic link") for ln in plain.stdout.splitlines())
    _refused(run_inproc("doctor", str(root), "--repair"), f"videos/{FRONT}")
    assert _snapshot(root.parent / "outside") == before
    assert not (root / layout.QUARANTINE_DIR).exists()


def test_repair_refuses_a_meta_folder_leading_out(root: Path) -> None:
    outside = _link_out(root, "meta")
    info = json.loads((outside / "info.json").read_text())
    info["total_frames"] += 1  # what repair would rewrite (a repairable totals finding)
    (outside / "info.json").write_text(json.dumps(info, indent=4))
    before = _snapshot(root.parent / "outside")
    _refused(run_inproc("doctor", str(root), "--repair"), f"{root / 'meta'}: a symbolic link")
    assert _snapshot(root.parent / "outside") == before


# -- record --resume (class 3) -------------------------------------------------------------------------------------
@pytest.mark.parametrize("rel", ["mcap", f"videos/{FRONT}"])
def test_resume_refuses_a_folder_leading_out(root: Path, rel: str) -> None:
    _link_out(root, rel)
    before = _snapshot(root.parent / "outside")
    inside = _snapshot(root)
    _refused(run_inproc("record", "--resume", "--out", str(root), "--n-episodes", "3"), rel)
    assert _snapshot(root.parent / "outside") == before
    assert _snapshot(root) == inside


# -- edits, view, stats recompute (class 4) ------------------------------------------------------------------------
EDITS = {
    "delete": ["episodes", "delete", "{ds}", "--episodes", "1", "--out", "{out}"],
    "filter": ["episodes", "filter", "{ds}", "--where", "length > 0", "--out", "{out}"],
    "split": ["episodes", "split", "{ds}", "--episodes", "0", "--out", "{out}"],
    "merge": ["episodes", "merge", "{clean}", "{ds}", "--out", "{out}"],
    "tasks": ["tasks", "set", "{ds}", "--episodes", "0", "--task", "x", "--out", "{out}"],
    "features": ["features", "remove", "{ds}", "--feature", WRIST, "--out", "{out}"],
    "stats": ["stats", "recompute", "{ds}", "--out", "{out}"],
    "reencode": ["videos", "reencode", "{ds}", "--codec", "h264", "--camera", FRONT, "--out", "{out}"],
    "view": ["view", "{ds}", "--save", "{out}.rrd"],
    "report": ["stats", "{ds}"],  # plain stats: reads the frames, writes nothing
}


def _edit_refused(name: str, root: Path, recorded: Path, rel: str) -> None:
    """`rel` linked out, the edit `name` refuses in one line naming it, writes nothing, and the outside files
    (whose frames it would have copied in) stay as they were."""
    _link_out(root, rel)
    before = _snapshot(root.parent / "outside")
    out = root.parent / "new"
    _refused(run_inproc(*[a.format(ds=root, out=out, clean=recorded) for a in EDITS[name]]), rel)
    assert _snapshot(root.parent / "outside") == before
    assert not out.exists() and not out.with_suffix(".rrd").exists()


@pytest.mark.parametrize("name", list(EDITS))
def test_edit_refuses_an_mp4_leading_out(root: Path, recorded: Path, name: str) -> None:
    _edit_refused(name, root, recorded, MP4)


def _data_in_chunk_1(root: Path) -> None:
    """Move the frames to data/chunk-001 (the episodes rows say so): a check of the templates at file (0, 0)
    alone does not see where they are."""
    for path in layout.episodes_files(root):
        table = pq.read_table(path)
        column = table.schema.get_field_index("data/chunk_index")
        pq.write_table(table.set_column(column, "data/chunk_index", pa.array([1] * table.num_rows)), path)
    (root / "data" / "chunk-000").rename(root / "data" / "chunk-001")


@pytest.mark.parametrize("rel", [f"videos/{FRONT}", "data/chunk-001", "meta"])
@pytest.mark.parametrize("name", ["delete", "view", "report"])
def test_edit_refuses_a_folder_leading_out(root: Path, recorded: Path, name: str, rel: str) -> None:
    if rel.startswith("data/"):
        _data_in_chunk_1(root)
    _edit_refused(name, root, recorded, rel)


def test_a_symlink_loop_is_one_line(root: Path) -> None:
    loop = root / "videos" / FRONT
    shutil.rmtree(loop)
    loop.symlink_to(FRONT)  # points at itself
    plain = run_inproc("doctor", str(root))
    assert plain.returncode == 1 and f"error   videos/{FRONT}: a symbolic link" in plain.stdout, plain
    _refused(run_inproc("doctor", str(root), "--repair"), "symlink loop")
    _refused(run_inproc("episodes", "delete", str(root), "--episodes", "1", "--out", str(root.parent / "n")), FRONT)


def test_a_link_inside_the_dataset_is_followed(root: Path) -> None:
    (root / "store").mkdir()
    (root / MP4).rename(root / "store" / "front.mp4")
    (root / MP4).symlink_to("../../../store/front.mp4")
    done = run_inproc("episodes", "delete", str(root), "--episodes", "1", "--out", str(root.parent / "new"))
    assert done.returncode == 0, done.stderr
    assert run_inproc("doctor", str(root.parent / "new")).returncode == 0


# -- --in-place through a DATASET given as a symlink (class 7) ------------------------------------------------------
def test_in_place_through_a_symlinked_dataset_edits_the_real_folder(root: Path) -> None:
    shutil.rmtree(root / "mcap")  # an --in-place edit refuses what it would not carry over
    link = root.parent / "link"
    link.symlink_to(root.name)
    done = run_inproc("episodes", "delete", str(link), "--episodes", "1", "--in-place")
    assert done.returncode == 0, done.stderr
    assert link.is_symlink() and link.resolve() == root.resolve()
    assert json.loads((root / layout.INFO_PATH).read_text())["total_episodes"] == 1
    assert sorted(p.name for p in root.parent.iterdir()) == ["ds", "link", "outside"]  # no `.replaced` left
    assert run_inproc("doctor", str(root)).returncode == 0
