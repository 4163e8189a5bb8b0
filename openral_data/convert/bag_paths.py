"""Which paths are bags, by their names alone (no bag library imported): what the bag source kinds detect and
`convert.sources.find_bags` lists."""

from __future__ import annotations

from pathlib import Path


def is_bag(path: Path) -> bool:
    if path.is_file():
        return path.suffix in {".bag", ".mcap"}
    return path.is_dir() and (path / "metadata.yaml").is_file()


def folder_bags(path: Path) -> list[Path]:
    """The bags directly in the folder `path` (hidden entries, such as an unfinished `.partial/`, ignored), in
    name order; [] for a file."""
    if not path.is_dir():
        return []
    return sorted(p for p in path.iterdir() if not p.name.startswith(".") and is_bag(p))


def is_bag_source(path: Path) -> bool:
    """`path` is a bag, or a folder holding bags."""
    return is_bag(path) or bool(folder_bags(path))
