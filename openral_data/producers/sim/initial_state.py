"""The checks a scene's `reset_to` makes before restoring an initial state: written by this kind of scene, in
this format, on the same task (ConfigError `initial_state: <key>: ...` otherwise)."""

from __future__ import annotations

from typing import Any

from openral_data.errors import ConfigError


def check_format(state: dict[str, Any], fmt: int) -> None:
    if state.get("format") != fmt:
        raise ConfigError(f"initial_state: format: expected {fmt}, got {state.get('format')!r}")


def check_recorded_on(state: dict[str, Any], key: str, expected: object, this: str = "this scene is") -> None:
    """`state[key]` must be `expected` (the scene's task, environment or kind)."""
    if state.get(key) != expected:
        raise ConfigError(f"initial_state: {key}: recorded on {state.get(key)!r}, {this} {expected!r}")


def check_envelope(state: dict[str, Any], fmt: int, kind: str) -> None:
    """`initial_state` must come from the same kind of scene and format this adapter writes."""
    check_format(state, fmt)
    check_recorded_on(state, "kind", kind)
