"""A package's names imported on first use (PEP 562): `__getattr__ = lazy_names(__name__, {name: module})` keeps
`import package` (and importing any of its modules) from importing every module the package re-exports."""

from __future__ import annotations

import importlib
import sys
from collections.abc import Callable
from typing import Any


def lazy_names(package: str, names: dict[str, str]) -> Callable[[str], Any]:
    """The `__getattr__` of `package`: `names` maps each public name to the module defining it, imported when the
    name is first used (then kept as the package's attribute)."""

    def __getattr__(name: str) -> Any:
        module = names.get(name)
        if module is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(module), name)
        setattr(sys.modules[package], name, value)
        return value

    return __getattr__
