"""A Hub repo id where a dataset path is expected resolves to lerobot's cache folder (`HF_LEROBOT_HOME/owner/name`),
offline; a missing one is one line and exit 2; an existing local folder of that name wins over the cache."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from openral_data.errors import NotFound
from openral_data.formats.repo_id import looks_like_repo_id, resolve_dataset
from tests.support.cli import run_cli
from tests.support.lerobot_written import LENGTHS, write_lerobot_dataset


@pytest.fixture(scope="module")
def written(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("written") / "ds"
    write_lerobot_dataset(root, with_success=True)
    return root


def _files(root: Path) -> list[str]:
    return sorted(str(p.relative_to(root)) for p in root.rglob("*"))


def test_repo_id_shapes() -> None:
    for ok in ("lerobot/pusht", "owner/name", "a_b/c-d.e", "Org1/ds_v2"):
        assert looks_like_repo_id(ok), ok
    for not_ok in ("pusht", "a/b/c", "/abs/x", "./x", "../x", "a/..", "a/.hidden", "-a/b", "a b/c", "a/"):
        assert not looks_like_repo_id(not_ok), not_ok


def test_an_existing_path_is_never_resolved(tmp_path: Path) -> None:
    local = tmp_path / "owner" / "name"
    local.mkdir(parents=True)
    assert resolve_dataset(local) == local
    with pytest.raises(NotFound, match=r"^not a repo id: no such file or directory$"):
        resolve_dataset("not a repo id")
    assert resolve_dataset("datasets/*") == Path("datasets/*")  # a glob: the command matches it


def test_info_and_doctor_read_a_repo_id_from_the_cache(written: Path, tmp_path: Path) -> None:
    home, work = tmp_path / "home", tmp_path / "work"
    work.mkdir()
    cached = home / "owner" / "name"
    shutil.copytree(written, cached)
    env = {"HF_LEROBOT_HOME": str(home)}
    res = run_cli("info", "owner/name", env=env, cwd=work)
    assert res.returncode == 0, res.stderr
    lines = res.stdout.splitlines()
    assert lines[0] == str(cached), res.stdout
    assert lines[1].split() == ["episodes", str(len(LENGTHS))] and lines[2].split() == ["frames", str(sum(LENGTHS))]
    res = run_cli("doctor", "owner/name", env=env, cwd=work)
    assert res.returncode == 0 and res.stdout.strip() == f"{cached}: healthy", (res.stdout, res.stderr)
    out = tmp_path / "edited"
    res = run_cli("episodes", "delete", "owner/name", "--episodes", "0", "--out", str(out), env=env, cwd=work)
    assert res.returncode == 0, res.stderr
    assert res.stdout.startswith(f"deleted: {out}  episodes {len(LENGTHS) - 1}"), res.stdout


def test_a_missing_repo_id_is_one_line_and_writes_nothing(tmp_path: Path) -> None:
    home, work = tmp_path / "home", tmp_path / "work"
    home.mkdir()
    work.mkdir()
    env = {"HF_LEROBOT_HOME": str(home)}
    for args in (("info", "ghost/none"), ("stats", "ghost/none"), ("convert", "ghost/none", "out")):
        res = run_cli(*args, env=env, cwd=work)
        assert res.returncode == 2, (args, res.stdout, res.stderr)
        where = home / "ghost" / "none"
        assert res.stderr == (
            f"error: ghost/none: no such folder, and not in the local cache (looked in {where}); add --download to "
            "fetch it from the Hub\n"
        ), res.stderr
    assert _files(home) == [] and _files(work) == []
    with pytest.raises(NotFound):
        resolve_dataset("ghost/none")  # whatever this process's cache is, it has no such repo


def test_a_local_folder_named_like_the_repo_id_wins(written: Path, tmp_path: Path) -> None:
    home, work = tmp_path / "home", tmp_path / "work"
    shutil.copytree(written, home / "owner" / "name")
    shutil.copytree(written, work / "owner" / "name")
    res = run_cli("doctor", "owner/name", env={"HF_LEROBOT_HOME": str(home)}, cwd=work)
    assert res.returncode == 0 and res.stdout.strip() == "owner/name: healthy", (res.stdout, res.stderr)
