"""Strict pydantic base and the YAML loader that turns validation errors into one-line messages."""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import yaml
from pydantic import BaseModel, ConfigDict, ValidationError

from openral_data.errors import ConfigError, NotRegularFile
from openral_data.paths import read_regular


class StrictModel(BaseModel):
    """Every schema rejects unknown keys and non-finite floats (`.nan`, `.inf`) and is immutable once loaded."""

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


class _UniqueKeyLoader(yaml.SafeLoader):
    """`yaml.SafeLoader` that refuses a mapping with the same key twice (PyYAML would keep the last silently)."""

    def construct_mapping(self, node: yaml.MappingNode, deep: bool = False) -> dict[Any, Any]:
        seen: set[Any] = set()
        for key_node, _ in node.value:
            key = self.construct_object(key_node, deep=deep)
            try:
                duplicate = key in seen
                seen.add(key)
            except TypeError:  # an unhashable key: the base class reports it
                break
            if duplicate:
                raise yaml.constructor.ConstructorError(None, None, f"duplicate key {key!r}", key_node.start_mark)
        return super().construct_mapping(node, deep=deep)

    def bounded_number(self, node: yaml.ScalarNode) -> Any:
        """An int or float scalar of at most `MAX_NUMBER_CHARS` characters (a 5000-digit integer is over
        Python's int-from-text limit: a ValueError, not a YAML error, before this)."""
        if len(str(node.value)) > MAX_NUMBER_CHARS:
            what = f"a number of {len(str(node.value))} characters (at most {MAX_NUMBER_CHARS})"
            raise yaml.constructor.ConstructorError(None, None, what, node.start_mark)
        make = yaml.SafeLoader.construct_yaml_int if node.tag.endswith(":int") else yaml.SafeLoader.construct_yaml_float
        return make(self, node)


MAX_NUMBER_CHARS = 100  # a YAML int or float (manifests hold small numbers)
_UniqueKeyLoader.add_constructor("tag:yaml.org,2002:int", _UniqueKeyLoader.bounded_number)
_UniqueKeyLoader.add_constructor("tag:yaml.org,2002:float", _UniqueKeyLoader.bounded_number)


_PLAIN_KEY = re.compile(r"[A-Za-z0-9_\-/]+")
_PYDANTIC_PREFIX = re.compile(r"^(Value error|Assertion failed), ")


def _loc(loc: tuple[int | str, ...]) -> str:
    out = ""
    for part in loc:
        if isinstance(part, int):
            out += f"[{part}]"
            continue
        key = part if _PLAIN_KEY.fullmatch(part) else repr(part)  # a key with dots, spaces or newlines, quoted
        out += f".{key}" if out else key
    return out or "<root>"


def plain_message(msg: object) -> str:
    """A pydantic error message on one line, without pydantic's own wording around a validator's text (`Value
    error, `, `Assertion failed, `)."""
    return _PYDANTIC_PREFIX.sub("", " ".join(str(msg).split()))


def format_validation_error(source: str, err: ValidationError) -> str:
    """`file: field: message` for each error, joined on one line."""
    parts = []
    for e in err.errors():
        msg = "unknown key" if e["type"] == "extra_forbidden" else plain_message(e["msg"])
        parts.append(f"{_loc(tuple(e['loc']))}: {msg}")
    return f"{source}: " + "; ".join(parts)


def read_yaml(path: Path) -> Any:
    """Parse a YAML file, raising ConfigError (naming the file) for a missing or unreadable file, text that is
    not UTF-8, bad syntax, a key given twice or nesting too deep to load."""
    try:
        text = read_regular(path).decode("utf-8")
    except FileNotFoundError:
        raise ConfigError(f"{path}: file not found") from None
    except IsADirectoryError:
        raise ConfigError(f"{path}: is a directory, expected a YAML file") from None
    except UnicodeDecodeError as exc:
        raise ConfigError(f"{path}: not UTF-8 text (byte {exc.start})") from None
    except NotRegularFile as exc:  # a FIFO or a device among the manifests would block every command listing them
        raise ConfigError(f"{path}: {exc.strerror}") from None
    except OSError as exc:
        raise ConfigError(f"{path}: cannot read: {exc.strerror or exc}") from None
    return parse_yaml(text, str(path))


def parse_yaml(text: str, source: str) -> Any:
    """`text` parsed as YAML (no duplicate keys); errors name `source` and the line."""
    try:
        return yaml.load(text, Loader=_UniqueKeyLoader)  # a SafeLoader subclass
    except RecursionError:
        raise ConfigError(f"{source}: invalid YAML: nested too deeply") from None
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" (line {mark.line + 1})" if mark is not None else ""
        problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
        raise ConfigError(f"{source}{where}: invalid YAML: {problem}") from None


def validate[M: BaseModel](model: type[M], data: Any, source: str) -> M:
    """Validate `data` against `model`; errors name `source` and the offending field."""
    if not isinstance(data, dict):
        raise ConfigError(f"{source}: expected a mapping at the top level, got {type(data).__name__}")
    try:
        return model.model_validate(data)
    except ValidationError as exc:
        raise ConfigError(format_validation_error(source, exc)) from None
    except RecursionError:  # a self-referencing YAML alias (`&a [*a]`)
        raise ConfigError(f"{source}: nested too deeply (a self-referencing alias?)") from None


def load_model[M: BaseModel](model: type[M], path: Path) -> M:
    return validate(model, read_yaml(path), str(path))
