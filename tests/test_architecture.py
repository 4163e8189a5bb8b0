"""House rules the import-linter contracts (`lint-imports`) do not cover: private names stay in their module,
and every package has a documented face."""

from __future__ import annotations

import ast
from pathlib import Path

PACKAGE = Path(__file__).resolve().parent.parent / "openral_data"


def _private(name: str) -> bool:
    return name.startswith("_") and not name.startswith("__")


def test_no_module_uses_another_modules_private_name() -> None:
    found = []
    for path in sorted(PACKAGE.rglob("*.py")):
        tree = ast.parse(path.read_text(), str(path))
        modules: set[str] = set()  # local names bound to openral_data modules or their members
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("openral_data"):
                for alias in node.names:
                    if _private(alias.name):
                        found.append(f"{path}:{node.lineno}: from {node.module} import {alias.name}")
                    modules.add(alias.asname or alias.name)
            elif isinstance(node, ast.Import):
                modules.update(
                    a.asname or a.name.split(".")[0] for a in node.names if a.name.startswith("openral_data")
                )
        for node in ast.walk(tree):
            if (
                isinstance(node, ast.Attribute)
                and _private(node.attr)
                and isinstance(node.value, ast.Name)
                and node.value.id in modules
            ):
                found.append(f"{path}:{node.lineno}: {node.value.id}.{node.attr}")
    assert not found, "\n".join(found)


def test_every_package_has_a_documented_face() -> None:
    """A docstring on every `__init__.py`; one that re-exports names says which in `__all__`."""
    for init in sorted(PACKAGE.rglob("__init__.py")):
        tree = ast.parse(init.read_text(), str(init))
        assert ast.get_docstring(tree), f"{init}: no docstring"
        reexports = any(
            isinstance(n, ast.ImportFrom) and n.module and n.module.startswith("openral_data") for n in tree.body
        )
        has_all = any(
            isinstance(n, ast.Assign) and any(isinstance(t, ast.Name) and t.id == "__all__" for t in n.targets)
            for n in tree.body
        )
        assert has_all or not reexports, f"{init}: re-exports names without __all__"


def test_the_package_is_typed() -> None:
    assert (PACKAGE / "py.typed").is_file()
