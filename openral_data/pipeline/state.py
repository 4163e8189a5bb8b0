"""The run folder of a pipeline and its completion markers.

```
<workdir>/<step>/<item>/        an output (dataset, results, bags, a report folder), built as
                                <step>/.<item>.partial-PID and renamed into place when complete
<workdir>/<step>/.<item>.done   item marker, written after the item's files are fsynced
<workdir>/<step>/.done.json     step marker: the step's config hash, outputs and summary (written last)
<workdir>/report.json           the final report of the last run
```
A marker is written only after the output it vouches for is durable, so a killed run resumes by skipping
what is marked and redoing the rest (an unmarked item is removed first; a killed item never got its name,
and its staging folder is removed as an orphan).
"""

from __future__ import annotations

import hashlib
import json
import shutil
from pathlib import Path
from typing import Any

from openral_data.errors import ConfigError
from openral_data.formats.atomic import fsync_dir, fsync_file, fsync_tree, read_control, write_bytes
from openral_data.formats.jsonfile import parse_json
from openral_data.formats.staging import clean_orphans
from openral_data.paths import contained, safe_name
from openral_data.pipeline.portable import portable
from openral_data.pipeline.schema import ENCODER_FIELDS, Step
from openral_data.runtime.parallel.workdir import workers_dirs

LATER_KINDS = ("train", "filter", "evaluate", "dagger")  # step kinds added after the first six
LATER_FIELDS = {"merge": ("common",), "filter": ("drop",), "train": ("threads",)}  # settings a step kind gained later


def config_hash(step: Step, folder: Path | None = None) -> str:
    """A step's settings, hashed. With `folder` (the pipeline file's folder, absolute) its file references are
    hashed relative to it with their content's digest (`portable`: a moved checkout keeps its hashes, an edited
    scene does not); without it, as the absolute paths the code before that hashed. The encoder settings a
    record step leaves unset, the step kinds added later that it is not and the settings added later
    (`LATER_FIELDS`) left at their defaults are left out, so a step written before they existed keeps its hash
    (a resumed run does not redo it)."""
    if folder is not None:
        step = portable(step, folder)
    unset = {k for k in ENCODER_FIELDS if step.record is not None and getattr(step.record, k) is None}
    later: dict[str, Any] = {k: True for k in LATER_KINDS if getattr(step, k) is None}
    for kind, names in LATER_FIELDS.items():
        spec = getattr(step, kind)
        if spec is not None:
            fields = type(spec).model_fields
            default = {n for n in names if getattr(spec, n) == fields[n].get_default(call_default_factory=True)}
            if default:
                later[kind] = default
    return hashlib.sha256(step.model_dump_json(exclude={"record": unset, **later}).encode()).hexdigest()[:16]


def make_durable(path: Path) -> None:
    if path.is_file():
        fsync_file(path)
        fsync_dir(path.parent)
        return
    fsync_tree(path)
    fsync_dir(path.parent)


def read_marker(path: Path) -> dict[str, Any] | None:
    """A marker's JSON object (None when there is none), read as a control file (`atomic.read_control`: no
    symlink, no FIFO); anything else there is refused in one line."""
    try:
        raw = read_control(path)
    except FileNotFoundError:
        return None
    try:
        data = parse_json(raw)
    except ValueError as exc:
        raise ConfigError(f"{path}: not a pipeline marker (invalid JSON: {exc}); delete it to redo the step") from None
    if not isinstance(data, dict):
        raise ConfigError(f"{path}: not a pipeline marker (not a JSON object); delete it to redo the step")
    return data


class StepState:
    """One step's folder ``<workdir>/<step id>``; every path below it is checked to stay inside `workdir`.

    `folder` is the pipeline file's folder: the markers carry the step's hash with its file references relative
    to it (`config_hash`); a marker written before that (the absolute paths' hash) is still accepted while
    nothing moved, and rewritten with the new hash."""

    def __init__(self, workdir: Path, step: Step, folder: Path | None = None) -> None:
        self.step = step
        self.workdir = workdir
        self.dir = contained(workdir, step.id, f"{workdir}: step {step.id}")
        self.marker = self.dir / ".done.json"
        self.hash = config_hash(step, folder)
        self.legacy = config_hash(step) if folder is not None else self.hash

    def _current(self, path: Path, data: dict[str, Any]) -> bool:
        """Whether the marker `data` at `path` vouches for this configuration; a legacy one is rewritten."""
        if data.get("config") == self.hash:
            return True
        if data.get("config") != self.legacy:
            return False
        write_bytes(path, json.dumps({**data, "config": self.hash}, indent=2).encode())
        return True

    def completed(self) -> dict[str, Any] | None:
        """The step marker if the step finished with this same configuration; an error if it changed."""
        done = read_marker(self.marker)
        if done is None:
            return None
        if not self._current(self.marker, done):
            raise ConfigError(
                f"step {self.step.id}: its configuration changed since it completed in {self.dir}; "
                f"delete that folder to run it again"
            )
        outputs = done.get("outputs")
        if not isinstance(outputs, dict):
            raise ConfigError(f"{self.marker}: outputs: not a mapping; delete it to redo the step")
        done["outputs"] = {name: str(self.item(name)) for name in outputs}  # where they are now, checked
        return done

    def item(self, name: object) -> Path:
        source = f"{self.marker}: output {name!r}"
        return contained(self.workdir, Path(self.step.id) / safe_name(name, source), source)

    def item_done(self, name: str) -> dict[str, Any] | None:
        path = self.dir / f".{safe_name(name, str(self.dir))}.done"
        data = read_marker(path)
        return data if data is not None and self._current(path, data) else None

    def start_item(self, name: str) -> Path:
        """A clean place for an item that has no marker (a half-written one from a killed run is removed)."""
        path = self.item(name)
        if path.is_symlink() or (path.exists() and not path.is_dir()):
            path.unlink()
        elif path.is_dir():
            shutil.rmtree(path)
        for workers in workers_dirs(self.dir, f".{name}.partial-*"):  # a killed `record --workers` item's shares
            if workers.is_symlink() or not workers.is_dir():
                workers.unlink()
            else:
                shutil.rmtree(workers, ignore_errors=True)
        self.dir.mkdir(parents=True, exist_ok=True)
        clean_orphans(self.dir)  # the staging folder of a killed run (`formats.staging`)
        return path

    def finish_item(self, name: str, summary: dict[str, Any]) -> None:
        make_durable(self.item(name))
        body = {"config": self.hash, "summary": summary}
        write_bytes(self.dir / f".{name}.done", json.dumps(body, indent=2).encode())

    def finish(self, outputs: dict[str, str], summary: dict[str, Any], seconds: float) -> dict[str, Any]:
        body = {
            "step": self.step.id,
            "kind": self.step.kind,
            "config": self.hash,
            "outputs": outputs,
            "summary": summary,
            "seconds": round(seconds, 3),
        }
        write_bytes(self.marker, json.dumps(body, indent=2).encode())
        return body
