"""An HDF5 file of untrusted origin names nothing outside itself (`check_contained`): external links, datasets
whose bytes live in other files (external storage) or are assembled from other files (virtual datasets) and links
of user-defined kinds are refused in one line before any data is read. The file's links are walked by HDF5's own
link visit (`H5Lvisit`: hard links only are descended, soft and external links are never followed), so a link to
a FIFO or to `/etc/passwd` is neither opened nor read."""

from __future__ import annotations

from pathlib import Path

import h5py

from openral_data.errors import DatasetError

MAX_LINKS = 2_000_000  # links walked in one file (a large MimicGen file has tens of thousands)


def check_contained(f: h5py.File, path: Path) -> None:
    """One line naming the first link or dataset of `f` that reads outside the file, or too many links."""
    seen = 0

    def visit(raw: bytes, link: h5py.h5l.LinkInfo) -> str | None:
        nonlocal seen
        seen += 1
        name = raw.decode("utf-8", "replace")
        if seen > MAX_LINKS:
            return f"/: more than {MAX_LINKS} links"
        if link.type == h5py.h5l.TYPE_SOFT:
            return None  # a path inside this file: every object it can reach is walked through its hard link
        if link.type != h5py.h5l.TYPE_HARD:
            external = link.type == h5py.h5l.TYPE_EXTERNAL
            return f"{name}: {'an external link to another file' if external else 'a user-defined link'}"
        return _outside(f, name)

    try:
        found = f.id.links.visit(visit, info=True)  # LinkInfo only: no link resolved
    except (OSError, ValueError, RuntimeError, KeyError) as exc:
        raise DatasetError(f"{path}: /: cannot walk the file's links ({type(exc).__name__})",
                           code="dataset.source.invalid") from None  # fmt: skip
    if found is not None:
        raise DatasetError(f"{path}: {found} (an HDF5 source holds its own data)", code="dataset.unsafe")


def _outside(f: h5py.File, name: str) -> str | None:
    """What reads outside the file in the hard-linked object `name` (None: nothing)."""
    if f.get(name, getclass=True) is not h5py.Dataset:
        return None
    ds = f[name]
    if ds.external:
        return f"{name}: external storage in another file"
    if ds.is_virtual:
        return f"{name}: a virtual dataset mapping other files"
    return None
