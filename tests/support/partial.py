"""Partial downloads of a dataset: a copy of it without some of its files, as `hf download --include 'meta/*'
'data/*'` (no ``videos/``) or an interrupted download (single mp4 or data files absent) leaves it."""

from __future__ import annotations

import shutil
from pathlib import Path

from openral_data.formats.lerobot_v3 import layout

NO_VIDEOS = ("videos",)  # `hf download --include 'meta/*' 'data/*'`


def lerobot_source(base: Path) -> Path:
    """A full dataset lerobot 0.6.1 wrote (`lerobot_written`: a video camera, an image camera, `next.success`) at
    `base/lerobot`, to take partial copies of."""
    from tests.support.lerobot_written import write_lerobot_dataset

    root = base / "lerobot"
    write_lerobot_dataset(root, with_success=True, image_camera=True)
    return root


def partial_copy(source: Path, dest: Path, absent: tuple[str, ...]) -> Path:
    """A copy of the dataset `source` at `dest` without the files or folders `absent` (relative paths; a folder
    goes whole). The copy has no content digests (a file left out is not a file changed)."""
    shutil.copytree(source, dest)
    for rel in absent:
        path = dest / rel
        assert path.exists(), path
        shutil.rmtree(path) if path.is_dir() else path.unlink()
    (dest / ".openral" / "digests.json").unlink(missing_ok=True)
    return dest


def first_video(root: Path, key: str) -> str:
    """The relative path of camera `key`'s first mp4."""
    return str(layout.video_files(root, key)[0].relative_to(root))


def first_data(root: Path) -> str:
    """The relative path of the first data parquet."""
    return str(layout.data_files(root)[0].relative_to(root))
