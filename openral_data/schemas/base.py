"""Strict pydantic base and the YAML loader that turns validation errors into one-line messages."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import yaml
from pydantic import BaseModel, ConfigDict, ValidationError

from openral_data.errors import ConfigError


class StrictModel(BaseModel):
    """Every schema rejects unknown keys and is immutable once loaded."""

    model_config = ConfigDict(extra="forbid", frozen=True)


def _loc(loc: tuple[int | str, ...]) -> str:
    out = ""
    for part in loc:
        out += f"[{part}]" if isinstance(part, int) else (f".{part}" if out else str(part))
    return out or "<root>"


def format_validation_error(source: str, err: ValidationError) -> str:
    """`file: field: message` for each error, joined on one line."""
    parts = []
    for e in err.errors():
        msg = e["msg"]
        if e["type"] == "extra_forbidden":
            msg = "unknown key"
        parts.append(f"{_loc(tuple(e['loc']))}: {msg}")
    return f"{source}: " + "; ".join(parts)


def read_yaml(path: Path) -> Any:
    """Parse a YAML file, raising ConfigError (naming the file) for a missing file or bad syntax."""
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise ConfigError(f"{path}: file not found") from None
    except IsADirectoryError:
        raise ConfigError(f"{path}: is a directory, expected a YAML file") from None
    try:
        return yaml.safe_load(text)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" (line {mark.line + 1})" if mark is not None else ""
        problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
        raise ConfigError(f"{path}{where}: invalid YAML: {problem}") from None


def validate[M: BaseModel](model: type[M], data: Any, source: str) -> M:
    """Validate `data` against `model`; errors name `source` and the offending field."""
    if not isinstance(data, dict):
        raise ConfigError(f"{source}: expected a mapping at the top level, got {type(data).__name__}")
    try:
        return model.model_validate(data)
    except ValidationError as exc:
        raise ConfigError(format_validation_error(source, exc)) from None


def load_model[M: BaseModel](model: type[M], path: Path) -> M:
    return validate(model, read_yaml(path), str(path))
