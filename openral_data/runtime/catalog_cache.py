"""What `list` found in each manifest file, kept between runs, so listing 80 manifests reads none of them again
(parsing their YAML and importing pydantic's schemas to validate them took most of `list scenes`' second).

One JSON file per installation in the user's cache folder (`manifests.cache_home()`, named after the package's
folder). Each entry is a manifest's path, its `stat` (size, mtime, ctime, inode, device: any write, `touch`,
`chmod` or replacement changes one) and what loading it gave: the listed fields, or the one-line error. The whole
file is for one version of the code that loads manifests (the `stat` of the modules of `openral_data/`,
`schemas/` and `runtime/`): another version starts afresh. Only regular files are cached (anything else is loaded
each time, so its error is the loader's own), and only fields of plain JSON types. A cache that cannot be read or
written is ignored: listing is never worse than without it.
"""

from __future__ import annotations

import hashlib
import json
import os
import stat
import tempfile
from collections.abc import Callable
from pathlib import Path

from openral_data import manifests
from openral_data.paths import read_regular

MAX_BYTES = 8 << 20  # ~300 bytes an entry
_PACKAGE = Path(__file__).resolve().parent.parent
_CODE_FOLDERS = (_PACKAGE, _PACKAGE / "schemas", _PACKAGE / "runtime")

Loaded = tuple[dict[str, object] | None, str | None]  # the listed fields, or why the manifest does not load


def _stamp(st: os.stat_result) -> list[int]:
    return [st.st_size, st.st_mtime_ns, st.st_ctime_ns, st.st_ino, st.st_dev]


def code_version() -> str:
    """A digest of the modules whose change could change what a manifest loads to."""
    stamps: list[object] = []
    for folder in _CODE_FOLDERS:
        with os.scandir(folder) as found:
            stamps += sorted([e.name, *_stamp(e.stat())] for e in found if e.name.endswith(".py"))
    return hashlib.sha256(json.dumps(stamps).encode()).hexdigest()


def cache_file() -> Path:
    return manifests.cache_home() / f"catalog-{hashlib.sha256(str(_PACKAGE).encode()).hexdigest()[:16]}.json"


def _plain(value: object) -> bool:
    if isinstance(value, list):
        return all(type(v) in (str, int) for v in value)
    return value is None or type(value) in (str, int)


class CatalogCache:
    """The cache file's entries of one run: `loaded` answers from it when a file is unchanged, else loads it;
    `save` writes back what this run saw of each kind it looked at."""

    def __init__(self) -> None:
        self._version = code_version()
        self._old: dict[str, dict[str, object]] = self._read()
        self._seen: dict[str, dict[str, object]] = {}
        self._changed = False

    def _read(self) -> dict[str, dict[str, object]]:
        try:
            doc = json.loads(read_regular(cache_file(), MAX_BYTES))
        except (OSError, ValueError, RecursionError):  # absent, unreadable, too large, not JSON
            return {}
        if not isinstance(doc, dict) or doc.get("code") != self._version or not isinstance(doc.get("kinds"), dict):
            return {}
        return {k: v for k, v in doc["kinds"].items() if isinstance(v, dict)}

    def loaded(self, kind: str, path: Path, load: Callable[[], Loaded]) -> Loaded:
        """What `load()` gives for the manifest `path` of `kind`, from the cache when the file is unchanged."""
        try:
            st = path.stat()
        except OSError:
            st = None
        if st is None or not stat.S_ISREG(st.st_mode):
            return load()  # not a regular file: its loader says what is wrong, every time
        key, stamp = str(path), _stamp(st)
        old = self._old.get(kind, {}).get(key)
        hit = _entry(old) if isinstance(old, dict) and old.get("stat") == stamp else None
        if hit is not None:
            self._seen.setdefault(kind, {})[key] = old
            return hit
        fields, error = load()
        entry: dict[str, object] = {"stat": stamp, "fields": fields, "error": error}
        if _entry(entry) is not None:  # plain JSON (else loaded again next time)
            self._seen.setdefault(kind, {})[key] = entry
            self._changed = True
        return fields, error

    def save(self) -> None:
        """Write the entries this run saw (the kinds it did not look at kept as they were), if any changed or
        went away; a failure to write is ignored."""
        kinds = {**self._old, **self._seen}
        if not self._changed and all(self._seen.get(k, {}).keys() == self._old.get(k, {}).keys() for k in self._seen):
            return
        data = json.dumps({"code": self._version, "kinds": kinds}, separators=(",", ":")).encode()
        target = cache_file()
        try:
            target.parent.mkdir(parents=True, exist_ok=True)
            fd, tmp = tempfile.mkstemp(dir=target.parent, prefix=f".{target.name}.", suffix=".tmp")
            try:
                with os.fdopen(fd, "wb") as fh:
                    fh.write(data)
                os.replace(tmp, target)  # a reader sees the old file or the new one, never half of one
            except OSError:
                Path(tmp).unlink(missing_ok=True)
                raise
        except OSError:
            pass


def _entry(cached: dict[str, object]) -> Loaded | None:
    """A cached entry's (fields, error), or None when it is not one this code writes."""
    fields, error = cached.get("fields"), cached.get("error")
    if not (fields is None or (isinstance(fields, dict) and all(_plain(v) for v in fields.values()))):
        return None
    if not (error is None or isinstance(error, str)) or (fields is None) == (error is None):
        return None
    return fields, error
