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
from openral_data.formats.atomic import fsync_dir, fsync_file, fsync_tree, write_bytes
from openral_data.formats.staging import clean_orphans
from openral_data.pipeline.schema import Step


def config_hash(step: Step) -> str:
    return hashlib.sha256(step.model_dump_json().encode()).hexdigest()[:16]


def make_durable(path: Path) -> None:
    if path.is_file():
        fsync_file(path)
        fsync_dir(path.parent)
        return
    fsync_tree(path)
    fsync_dir(path.parent)


class StepState:
    def __init__(self, workdir: Path, step: Step) -> None:
        self.step = step
        self.dir = workdir / step.id
        self.marker = self.dir / ".done.json"
        self.hash = config_hash(step)

    def completed(self) -> dict[str, Any] | None:
        """The step marker if the step finished with this same configuration; an error if it changed."""
        if not self.marker.exists():
            return None
        done: dict[str, Any] = json.loads(self.marker.read_text())
        if done.get("config") != self.hash:
            raise ConfigError(
                f"step {self.step.id}: its configuration changed since it completed in {self.dir}; "
                f"delete that folder to run it again"
            )
        return done

    def item(self, name: str) -> Path:
        return self.dir / name

    def item_done(self, name: str) -> dict[str, Any] | None:
        path = self.dir / f".{name}.done"
        if not path.exists():
            return None
        data: dict[str, Any] = json.loads(path.read_text())
        return data if data.get("config") == self.hash else None

    def start_item(self, name: str) -> Path:
        """A clean place for an item that has no marker (a half-written one from a killed run is removed)."""
        path = self.item(name)
        if path.is_dir():
            shutil.rmtree(path)
        elif path.exists():
            path.unlink()
        for workers in self.dir.glob(f"..{name}.partial-*.workers-*"):  # a killed `record --workers` item's shares
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
