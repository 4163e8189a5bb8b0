"""Errors a user can cause. The CLI prints them as one line and exits non-zero; anything else is a bug."""

from __future__ import annotations


class OpenralError(Exception):
    """A user-facing error: bad input, an incompatible combination, an unusable output path."""


class ConfigError(OpenralError):
    """A manifest or scene file is invalid. The message names the file and the field."""


class ContractViolation(OpenralError):
    """A frame did not satisfy the rSkill's state/action contract or the declared cameras."""


class CompatibilityError(OpenralError):
    """Scene, robot and rSkill do not fit together; raised before the first episode."""
