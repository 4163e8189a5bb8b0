"""The workspace a malformed-input case builds its bad input in, and the byte snapshot that proves nothing already
written changed (tests/malformed)."""

from __future__ import annotations

import shutil
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from tests.support.home import BUILTIN


def snapshot(root: Path) -> dict[str, bytes | None]:
    """Every file under `root` (its bytes) and every folder (None), by relative path; symlinks not followed."""
    out: dict[str, bytes | None] = {}
    for p in sorted(root.rglob("*")):
        rel = str(p.relative_to(root))
        out[rel] = None if p.is_dir() and not p.is_symlink() else p.read_bytes() if p.is_file() else b"<other>"
    return out


@dataclass(frozen=True)
class Workspace:
    """`root`: the case's folder; `home`: its project (robots/, rskills/, scenes/); `dataset`: a small recorded
    dataset to copy; `bag`: a small valid plain MCAP bag to copy or cut; `results`: the dataset's replay results."""

    root: Path
    home: Path
    dataset: Path
    bag: Path
    results: Path

    def res(self, name: str = "res") -> Path:
        """A fresh copy of the replay results under root."""
        dst = self.root / name
        shutil.copytree(self.results, dst)
        return dst

    def ds(self, name: str = "ds") -> Path:
        """A fresh copy of the recorded dataset under root."""
        dst = self.root / name
        shutil.copytree(self.dataset, dst)
        return dst

    def path(self, rel: str) -> Path:
        p = self.root / rel
        p.parent.mkdir(parents=True, exist_ok=True)
        return p

    def write(self, rel: str, data: bytes | str) -> Path:
        p = self.path(rel)
        if isinstance(data, str):
            p.write_text(data)
        else:
            p.write_bytes(data)
        return p

    def yaml(self, rel: str, data: Any) -> Path:
        return self.write(rel, yaml.safe_dump(data, sort_keys=False))

    def repo_yaml(self, rel: str) -> Any:
        """A built-in manifest (`rel` under openral_data/builtin/), parsed (to change one field of it)."""
        return yaml.safe_load((BUILTIN / rel).read_text())
