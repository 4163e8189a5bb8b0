"""`meta/openral.json`, our provenance: which openral-data wrote the dataset, from what (`Origin`: the scene,
rSkill and robot of a recording, the HAL and safety of a robot recording, the dataset a replay came from, the
bag a conversion read), with which writer settings, and the edit that made it (`EditRecord`).

One model for every writer (`record`, `record --hal`, `replay --record`, `convert`, the edits) and every reader
(replay rebuilds the scene from it, metrics and the Hub card name the scene, rSkill and robot). Writing is
byte-stable: the keys come out in the order they always had (`to_json`). Reading is tolerant, as the file is
untrusted (a dataset written by an older version, or edited by hand): a missing key reads as None, a value of
the wrong type is kept aside in `extra` (written back as it was, never interpreted), a key we do not know too.
A dataset written by lerobot or converted by another tool has no such file (`read_provenance` -> None).
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any

from openral_data.errors import DatasetError
from openral_data.formats.jsonfile import read_json
from openral_data.formats.lerobot_v3 import layout

WRITER = "openral-data"


def _str(value: Any) -> str | None:
    return value if isinstance(value, str) else None


def _dict(value: Any) -> dict[str, Any] | None:
    return value if isinstance(value, dict) else None


@dataclass(frozen=True)
class Recorded:
    """A config file as it was recorded: where it was read from and its full, validated content."""

    path: str | None
    config: dict[str, Any] | None

    def to_json(self) -> dict[str, Any]:
        return {"path": self.path, "config": self.config}

    @classmethod
    def from_json(cls, data: dict[str, Any]) -> Recorded:
        return cls(_str(data.get("path")), _dict(data.get("config")))


@dataclass(frozen=True)
class HalOrigin:
    """What `record --hal` recorded from: the robot, the HAL mode and class, the scene of a scene HAL."""

    robot: str | None
    mode: str | None
    kind: str | None
    scene: str | None

    def to_json(self) -> dict[str, Any]:
        return {"robot": self.robot, "mode": self.mode, "kind": self.kind, "scene": self.scene}

    @classmethod
    def from_json(cls, data: dict[str, Any]) -> HalOrigin:
        return cls(_str(data.get("robot")), _str(data.get("mode")), _str(data.get("kind")), _str(data.get("scene")))


@dataclass(frozen=True)
class SafetyRecord:
    """The safety filter a HAL recording ran with: its mode and the robot manifest's limits."""

    mode: str | None
    config: dict[str, Any] | None

    def to_json(self) -> dict[str, Any]:
        return {"mode": self.mode, "config": self.config}

    @classmethod
    def from_json(cls, data: dict[str, Any]) -> SafetyRecord:
        return cls(_str(data.get("mode")), _dict(data.get("config")))


@dataclass(frozen=True)
class ReplayOrigin:
    """The dataset `replay --record` replayed, and how (actions | policy | closed-loop)."""

    dataset: str | None
    mode: str | None

    def to_json(self) -> dict[str, Any]:
        return {"dataset": self.dataset, "mode": self.mode}

    @classmethod
    def from_json(cls, data: dict[str, Any]) -> ReplayOrigin:
        return cls(_str(data.get("dataset")), _str(data.get("mode")))


# `Origin`'s fields that are JSON objects in the file, and the model each one reads into
_NESTED: dict[str, Any] = {
    "scene": Recorded,
    "hal": HalOrigin,
    "rskill": Recorded,
    "safety": SafetyRecord,
    "replayed_from": ReplayOrigin,
}


@dataclass(frozen=True)
class Origin:
    """`schema_metadata`: where the frames came from. Each writer fills its own fields; None is left out.

    The field order is the file's key order (the same for every writer that has the keys)."""

    openral_data_version: str | None = None
    scene: Recorded | None = None
    hal: HalOrigin | None = None
    rskill: Recorded | None = None
    robot: str | None = None
    safety: SafetyRecord | None = None
    replayed_from: ReplayOrigin | None = None
    converted_from: str | None = None
    mapping: dict[str, Any] | None = None
    exported_from: str | None = None
    extra: dict[str, Any] = field(default_factory=dict)  # keys we do not know, values of the wrong type: verbatim

    def to_json(self) -> dict[str, Any]:
        out: dict[str, Any] = {}
        for f in fields(self):
            value = getattr(self, f.name)
            if f.name == "extra" or value is None:
                continue
            out[f.name] = value.to_json() if f.name in _NESTED else value
        out.update(self.extra)
        return out

    @classmethod
    def from_json(cls, data: dict[str, Any]) -> Origin:
        known: dict[str, Any] = {}
        extra: dict[str, Any] = {}
        names = {f.name for f in fields(cls)} - {"extra"}
        for key, value in data.items():
            if key not in names:
                extra[key] = value
            elif key in _NESTED:
                if isinstance(value, dict):
                    known[key] = _NESTED[key].from_json(value)
                else:
                    extra[key] = value
            elif (key == "mapping" and isinstance(value, dict)) or (key != "mapping" and isinstance(value, str)):
                known[key] = value
            else:
                extra[key] = value
        return cls(**known, extra=extra)

    def present(self, key: str) -> bool:
        """Whether the file has `key` at all (a value of the wrong type included)."""
        return key in self.extra or getattr(self, key, None) is not None

    @property
    def scene_id(self) -> str | None:
        """The recorded scene's id (`scene.config.scene.id`), if it is a string."""
        config = self.scene.config if self.scene is not None else None
        scene = _dict(config.get("scene")) if config else None
        return _str(scene.get("id")) if scene else None

    @property
    def rskill_id(self) -> str | None:
        """The recorded rSkill's id (`rskill.config.id`), if it is a string."""
        config = self.rskill.config if self.rskill is not None else None
        return _str(config.get("id")) if config else None


@dataclass(frozen=True)
class EditSource:
    """One dataset an edit read episodes from: its path, the episodes taken, its own `schema_metadata`."""

    path: str | None
    episodes: list[Any]
    origin: Origin | None

    def to_json(self) -> dict[str, Any]:
        return {
            "path": self.path,
            "episodes": self.episodes,
            "schema_metadata": self.origin.to_json() if self.origin is not None else {},
        }

    @classmethod
    def from_json(cls, data: dict[str, Any]) -> EditSource:
        episodes = data.get("episodes")
        meta = data.get("schema_metadata")
        return cls(
            _str(data.get("path")),
            episodes if isinstance(episodes, list) else [],
            Origin.from_json(meta) if isinstance(meta, dict) else None,
        )


@dataclass(frozen=True)
class EditRecord:
    """The `edit` block: the operation, its sources, and what the operation adds (`details`: codec, size, ...)."""

    op: str | None
    sources: list[EditSource]
    details: dict[str, Any] = field(default_factory=dict)

    def to_json(self) -> dict[str, Any]:
        return {"op": self.op, "sources": [s.to_json() for s in self.sources], **self.details}

    @classmethod
    def from_json(cls, data: dict[str, Any]) -> EditRecord:
        sources = data.get("sources")
        return cls(
            _str(data.get("op")),
            [EditSource.from_json(s) for s in sources if isinstance(s, dict)] if isinstance(sources, list) else [],
            {k: v for k, v in data.items() if k not in ("op", "sources")},
        )


@dataclass(frozen=True)
class Provenance:
    """The whole of `meta/openral.json`.

    `origin` is None when the file's `schema_metadata` is not an object (an empty `Origin` when it is missing);
    `config` is the writer's storage settings (codec, crf, g, file sizes, chunk size)."""

    origin: Origin | None
    config: dict[str, Any] | None
    writer: str | None = WRITER
    edit: EditRecord | None = None
    extra: dict[str, Any] = field(default_factory=dict)

    def to_json(self) -> dict[str, Any]:
        out: dict[str, Any] = {
            "writer": self.writer,
            "schema_metadata": self.origin.to_json() if self.origin is not None else {},
            "config": self.config,
        }
        if self.edit is not None:
            out["edit"] = self.edit.to_json()
        out.update(self.extra)
        return out

    def dumps(self) -> bytes:
        """The file's bytes."""
        return json.dumps(self.to_json(), indent=2).encode()

    @classmethod
    def from_json(cls, data: dict[str, Any]) -> Provenance:
        meta = data.get("schema_metadata", {})
        edit = data.get("edit")
        return cls(
            origin=Origin.from_json(meta) if isinstance(meta, dict) else None,
            config=_dict(data.get("config")),
            writer=_str(data.get("writer")),
            edit=EditRecord.from_json(edit) if isinstance(edit, dict) else None,
            extra={k: v for k, v in data.items() if k not in ("writer", "schema_metadata", "config", "edit")},
        )


def read_provenance(root: Path) -> Provenance | None:
    """`root`'s `meta/openral.json`; None for a dataset without it (written by lerobot, or converted by another
    tool). Not JSON, or not a JSON object: `DatasetError`."""
    try:
        data = read_json(root / layout.OPENRAL_PATH)
    except FileNotFoundError:
        return None
    if not isinstance(data, dict):
        raise DatasetError(
            f"{root / layout.OPENRAL_PATH}: expected a JSON object, got {type(data).__name__}", code="dataset.invalid"
        )
    return Provenance.from_json(data)
