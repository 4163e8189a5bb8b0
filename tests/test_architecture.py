"""House rules the import-linter contracts (`lint-imports`) do not cover: private names stay in their module (in
the package, its tests and benchmarks alike), and every package has a documented face."""

from __future__ import annotations

import ast
from collections.abc import Iterator
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PACKAGE = ROOT / "openral_data"
TESTS = ROOT / "tests"
BENCHMARKS = ROOT / "benchmarks"


def _private(name: str) -> bool:
    return name.startswith("_") and not name.startswith("__")


def _private_uses(path: Path) -> list[str]:
    """Where `path` imports or touches a `_private` name of an openral_data module: `from m import _x`, `m._x`,
    `setattr(m, "_x", ...)` / `monkeypatch.setattr(m, "_x", ...)` and `"openral_data.<m>._x"` strings."""
    found = []
    tree = ast.parse(path.read_text(), str(path))
    modules: set[str] = set()  # local names bound to openral_data modules or their members
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("openral_data"):
            for alias in node.names:
                if _private(alias.name):
                    found.append(f"{path}:{node.lineno}: from {node.module} import {alias.name}")
                modules.add(alias.asname or alias.name)
        elif isinstance(node, ast.Import):
            modules.update(a.asname or a.name.split(".")[0] for a in node.names if a.name.startswith("openral_data"))
    for node in ast.walk(tree):
        if isinstance(node, ast.expr) and (use := _private_use(node, modules)):
            found.append(f"{path}:{node.lineno}: {use}")
    return found


def _private_use(node: ast.expr, modules: set[str]) -> str | None:
    """`m._x`, `f(m, "_x", ...)` (setattr, monkeypatch.setattr, patch.object) or `"openral_data.<m>._x"`."""
    if isinstance(node, ast.Attribute) and _private(node.attr) and _names(node.value, modules):
        return ast.unparse(node)
    if isinstance(node, ast.Call) and len(node.args) >= 2 and _names(node.args[0], modules):
        name = node.args[1]
        if isinstance(name, ast.Constant) and isinstance(name.value, str) and _private(name.value):
            return f"{ast.unparse(node.func)}({ast.unparse(node.args[0])}, {name.value!r}, ...)"
    if isinstance(node, ast.Constant) and isinstance(node.value, str) and node.value.startswith("openral_data."):
        return repr(node.value) if any(_private(part) for part in node.value.split(".")) else None
    return None


def _names(node: ast.expr, modules: set[str]) -> bool:
    return isinstance(node, ast.Name) and node.id in modules


def test_no_module_uses_another_modules_private_name() -> None:
    found = [line for path in sorted(PACKAGE.rglob("*.py")) for line in _private_uses(path)]
    assert not found, "\n".join(found)


def test_no_test_or_benchmark_uses_a_private_name_of_the_package() -> None:
    """Tests reach the package through its public names; a fault injected on purpose goes through a documented
    seam (e.g. `formats.mcap.writer.EpisodeBag.write_frame`), never a `_private` one."""
    paths = [p for root in (TESTS, BENCHMARKS) for p in sorted(root.rglob("*.py"))]
    found = [line for path in paths for line in _private_uses(path)]
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


MAX_MODULE_LINES = 600
MAX_FUNCTION_LINES = 60


def _functions(tree: ast.AST, prefix: str = "") -> Iterator[tuple[str, ast.FunctionDef | ast.AsyncFunctionDef]]:
    """(qualified name, node) of every function in `tree`, methods and nested functions included."""
    for node in ast.iter_child_nodes(tree):
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
            yield prefix + node.name, node
            yield from _functions(node, f"{prefix}{node.name}.")
        elif isinstance(node, ast.ClassDef):
            yield from _functions(node, f"{prefix}{node.name}.")
        else:
            yield from _functions(node, prefix)


def _too_long() -> set[str]:
    found = set()
    for root in (PACKAGE, TESTS, BENCHMARKS):
        for path in sorted(root.rglob("*.py")):
            lines = path.read_text().splitlines()
            name = str(path.relative_to(ROOT))
            if len(lines) > MAX_MODULE_LINES:
                found.add(name)
            if root != PACKAGE:
                continue
            for qualname, node in _functions(ast.parse("\n".join(lines), name)):
                length = (node.end_lineno or node.lineno) - node.lineno + 1
                if length > MAX_FUNCTION_LINES:
                    found.add(f"{name}::{qualname}")
    return found


def test_no_module_over_600_lines_and_no_function_over_60() -> None:
    """Modules of the package, tests and benchmarks stay under 600 lines; no function of the package (the CLI's
    included) is over 60 lines: a long one is split, never excused."""
    found = _too_long()
    assert not found, "too long (split it):\n" + "\n".join(sorted(found))
