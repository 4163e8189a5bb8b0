"""The one rule for a path that comes out of a file's contents: it stays inside its root (`contained`,
`safe_name`), and a file read by name is a regular file (`regular_file`, `read_regular`); an output folder
given on the command line must be creatable (`check_creatable`). Where manifests and outputs live is
`openral_data.manifests`.
"""

from __future__ import annotations

import errno
import os
import re
import stat
import string
from pathlib import Path

from openral_data.errors import DatasetError, NotRegularFile, UsageError


def contained(root: Path, relative: str | os.PathLike[str], source: str) -> Path:
    """`root / relative`, refused unless it stays inside `root`.

    `relative` comes from untrusted file contents (a journal entry, a path template, a feature key, an id used
    as a folder name); `source` names where (``"<file>: <field>"``) for the one-line refusal. Absolute paths,
    any ``..`` component, NUL bytes and symlinks (anywhere on the way) that lead out are refused, before
    anything touches the filesystem beyond resolving the path.
    """
    text = os.fspath(relative)
    if "\x00" in text:
        raise DatasetError(f"{source}: path {text!r} holds a NUL byte", code="dataset.unsafe")
    rel = Path(text)
    if rel.is_absolute():
        raise DatasetError(f"{source}: path {text!r} is absolute; it must stay inside {root}", code="dataset.unsafe")
    path = root / rel
    linked = _link_on_the_way(root, rel)
    if ".." in rel.parts or (linked and not _resolved(path, source).is_relative_to(root.resolve())):
        raise DatasetError(f"{source}: path {text!r} leads outside {root}", code="dataset.unsafe")
    return path


def from_template(root: Path, template: object, values: dict[str, object], source: str) -> Path:
    """A dataset file named by a path template from its metadata (info.json's ``data_path``, ``video_path``):
    `template` formatted with `values` and `contained` in `root`, else one line naming `source`."""
    if not isinstance(template, str):
        raise DatasetError(f"{source}: {template!r} is not a path template", code="dataset.invalid")
    check_template(template, values, source)
    try:
        rel = template.format(**values)
    except (KeyError, IndexError, ValueError, AttributeError, TypeError) as exc:
        raise DatasetError(
            f"{source}: {template!r} is not a usable path template ({exc})", code="dataset.invalid"
        ) from None
    if any(len(os.fsencode(part)) > MAX_NAME_BYTES for part in Path(rel).parts):
        raise DatasetError(f"{source}: {template[:80]!r} makes a file name over {MAX_NAME_BYTES} bytes",
                           code="dataset.invalid")  # fmt: skip
    return contained(root, rel, source)


MAX_TEMPLATE_CHARS = 512
MAX_NAME_BYTES = 255  # one path component (the file systems' limit)
MAX_FIELD_WIDTH = 10  # `{file_index:03d}`-style widths, as lerobot writes them (at most 10 digits)
_FIELD_SPEC = re.compile(r"0?([1-9]\d?)?d")


def check_template(template: str, values: dict[str, object], source: str) -> None:
    """`template` is in the forms lerobot writes, before it is formatted (nothing is allocated for a width of
    10**9): bounded length, only the fields of `values`, each plain or an integer with a small zero-padded width
    (`{chunk_index:03d}`), no conversion, attribute or index; anything else is one line naming `source`."""
    if len(template) > MAX_TEMPLATE_CHARS:
        raise DatasetError(f"{source}: a path template of {len(template)} characters", code="dataset.invalid")
    try:
        fields = list(string.Formatter().parse(template))
    except ValueError as exc:
        raise DatasetError(
            f"{source}: {template[:80]!r} is not a path template ({exc})", code="dataset.invalid"
        ) from None
    for _, name, spec, conversion in fields:
        if name is None:
            continue
        match = _FIELD_SPEC.fullmatch(spec or "")
        width_ok = not spec or (match is not None and int(match.group(1) or 0) <= MAX_FIELD_WIDTH)
        if name not in values or conversion is not None or not width_ok or (spec and isinstance(values[name], str)):
            shown = "{" + name + (f"!{conversion}" if conversion else "") + (f":{spec}" if spec else "") + "}"
            raise DatasetError(
                f"{source}: {shown[:60]} is not a field lerobot writes (fields: "
                f"{', '.join(sorted(values))}; widths up to {MAX_FIELD_WIDTH}, as {{chunk_index:03d}})",
                code="dataset.invalid",
            )


def _link_on_the_way(root: Path, rel: Path) -> bool:
    """Whether a component of `rel` below `root` is a symlink (one `lstat` each, up to the first missing one):
    without one, `root / rel` is inside `root` and needs no full resolve (the common case, per file written)."""
    here = os.fspath(root)
    for part in rel.parts:
        here = os.path.join(here, part)
        try:
            if stat.S_ISLNK(os.lstat(here).st_mode):
                return True
        except (FileNotFoundError, NotADirectoryError):
            return False
    return False


def _resolved(path: Path, source: str) -> Path:
    try:
        return path.resolve()
    except (RuntimeError, OSError) as exc:  # a symlink loop (RuntimeError before Python 3.13)
        raise DatasetError(f"{source}: cannot resolve {path}: {exc}", code="dataset.unsafe") from None


def contained_all(root: Path, relatives: list[str], source: str) -> list[Path]:
    """`contained` for many paths at once, resolving each distinct folder once (a commit journal or a digest
    delta names a handful of folders): same refusals, one `lstat` per path instead of one per component."""
    folders: dict[str, Path] = {}
    out: list[Path] = []
    for text in relatives:
        if "\x00" in text:
            raise DatasetError(f"{source}: path {text!r} holds a NUL byte", code="dataset.unsafe")
        folder, _, name = text.replace(os.sep, "/").rpartition("/")
        if folder not in folders:
            folders[folder] = contained(root, folder or ".", source)
        if name in ("", ".", ".."):
            path = contained(root, text, source)
        else:
            path = folders[folder] / name
            if path.is_symlink():
                path = contained(root, text, source)
        out.append(path)
    return out


def safe_name(name: object, source: str) -> str:
    """`name` if it can be one path component (a feature key, a robot id, a step id), else a one-line refusal.

    A component is a non-empty string without ``/``, ``\\`` or NUL, and not ``.`` or ``..``.
    """
    if not isinstance(name, str) or not name or name in (".", "..") or any(c in name for c in "/\\\x00"):
        raise DatasetError(f"{source}: {name!r} cannot be a file or folder name", code="dataset.unsafe")
    return name


def regular_file(path: Path) -> Path:
    """`path` if it is a regular file (symlinks followed); a FIFO or a device would block the reader for ever.

    For files a reader opens by name (parquet, mp4). A missing file raises `FileNotFoundError` as `os.stat`.
    """
    if not stat.S_ISREG(os.stat(path).st_mode):
        raise DatasetError(
            f"{path}: not a regular file (a FIFO, device or folder); refusing to read it", code="dataset.unsafe"
        )
    return path


def read_regular(path: Path, limit: int | None = None) -> bytes:
    """The bytes of `path` (symlinks followed) if it is a regular file, checked before reading: opened
    ``O_NONBLOCK`` and `fstat`-ed, so a FIFO or a device cannot block the reader. A folder raises
    `IsADirectoryError`, a FIFO or device `NotRegularFile`, a missing file `FileNotFoundError`, a file of more
    than `limit` bytes `ValueError` (read no further than one byte past it)."""
    fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | os.O_CLOEXEC)
    try:
        mode = os.fstat(fd).st_mode
        if stat.S_ISDIR(mode):
            raise IsADirectoryError(errno.EISDIR, "is a directory")
        if not stat.S_ISREG(mode):
            raise NotRegularFile(errno.EINVAL, "not a regular file (a FIFO or device); refusing to read it")
        chunks, size = [], 0
        while (limit is None or size <= limit) and (chunk := os.read(fd, 1 << 20)):
            chunks.append(chunk)
            size += len(chunk)
    finally:
        os.close(fd)
    if limit is not None and size > limit:
        raise ValueError(f"larger than {limit} bytes")
    return b"".join(chunks)


def check_creatable(out: Path, source: str, *, folder: bool = True) -> None:
    """Refuse, before anything is written, an output that cannot be made because a file stands where one of its
    parent folders would be (`--out notes.txt/new`), or (`folder`) because `out` itself is a file."""
    if folder and (out.exists() or out.is_symlink()) and not out.is_dir():
        raise UsageError(f"{out}: {source} exists and is not a directory")
    for parent in out.parents:
        if parent.exists() or parent.is_symlink():
            if not parent.is_dir():
                raise UsageError(f"{out}: {source}: cannot create it, {parent} is a file, not a folder")
            return


def check_file_output(out: Path, source: str) -> None:
    """`check_creatable` for a file option (`stats --plot`, `view --save`), and the nearest existing folder on its
    way must be writable: a read-only mount or a folder without permission is one line before any work."""
    check_creatable(out, source, folder=False)
    parent = next((p for p in out.absolute().parents if p.is_dir()), None)
    if parent is not None and not os.access(parent, os.W_OK):
        raise UsageError(f"{out}: {source}: cannot write into {parent} (read-only or no permission)")
