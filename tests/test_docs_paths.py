"""Keep the map true: every repository path and every dotted `openral_data` name that a docstring, a comment or a doc
page (README.md, docs/*.md, benchmarks/README.md) names exists.

A path is a token naming a `.py`/`.md`/`.sh` file, or one starting with a top-level folder of the repository
(`tests/...`, `docs/...`) or with a package of `openral_data/` and ending in `/` (`record/parallel/`). It exists
when it is found from the repository root, from `openral_data/`, from the folder of the file that names it or any
folder above it, or from a folder the same paragraph names (`openral_data/record/` — `sim.py`, `options.py`); a
bare file name (`bench_stats.py`) may also sit in a top-level folder. Dataset layouts (`meta/info.json`,
`videos/<cam>/...`), user paths (`./scenes`, `~/.config/...`), hidden folders (`.openral/`), placeholders
(`pipelines/NAME.yaml`) and `a/b` alternatives are not paths. A dotted name exists when its longest module prefix
is a module of the package and the next part (if any) is defined in it.
"""

from __future__ import annotations

import ast
import importlib
import io
import re
import tokenize
from collections.abc import Iterator
from functools import cache
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PACKAGE = ROOT / "openral_data"
TOP = ("openral_data", "tests", "docs", "scripts", "benchmarks", "pipelines")
SUBPACKAGES = tuple(p.name for p in PACKAGE.iterdir() if (p / "__init__.py").is_file() or p.name == "builtin")
FILES = (".py", ".md", ".sh")
PAGES = (ROOT / "README.md", ROOT / "benchmarks" / "README.md", *sorted((ROOT / "docs").glob("*.md")))

# Named on purpose though not in the repository; each with why.
ALLOWED = {
    "lerobot-v3-format.md": "the LeRobot v3 format reference the writer was built from, kept outside the repository",
    "card_template.md": "lerobot's dataset card template, inside the installed lerobot package",
    "benchmarks/results": "what the benchmarks write (git-ignored)",
    "lerobot/": "a path inside the installed lerobot package",
}
ENTRY_POINT_GROUPS = {"openral_data.scenes", "openral_data.robots"}  # plug-in groups (docs/plugins.md), not modules

TOKEN = re.compile(r"(?<![\w./<>{}*$~:@=-])(?:\.\./)*[\w.-]+(?:/[\w.-]+)*/?")
DOTTED = re.compile(r"(?<![\w./-])openral_data(?:\.\w+)+")
PLACEHOLDER = re.compile(r"[A-Z][A-Z0-9_]*")


@cache
def _texts() -> list[tuple[Path, str]]:
    return list(_read_texts())


def _read_texts() -> Iterator[tuple[Path, str]]:
    """(file, text): every docstring and comment of the Python sources, every section of the doc pages."""
    for base in ("openral_data", "tests", "benchmarks"):
        for path in sorted((ROOT / base).rglob("*.py")):
            source = path.read_text()
            for node in ast.walk(ast.parse(source, str(path))):
                if isinstance(node, ast.Module | ast.ClassDef | ast.FunctionDef | ast.AsyncFunctionDef):
                    doc = ast.get_docstring(node, clean=False)
                    if doc:
                        yield path, doc
            for token in tokenize.generate_tokens(io.StringIO(source).readline):
                if token.type == tokenize.COMMENT:
                    yield path, token.string
    for page in PAGES:
        for section in re.split(r"\n(?=#+ )", page.read_text()):
            yield page, section


def _is_path(token: str) -> bool:
    if "/" not in token and not token.endswith(FILES):
        return False
    parts = token.rstrip("/").split("/")
    if any(part == "." or (part.startswith(".") and part != "..") for part in parts):
        return False  # ./user/path, .openral/, .partial/
    if any(PLACEHOLDER.fullmatch(Path(part).stem) and Path(part).stem != "README" for part in parts):
        return False  # OUT/, pipelines/NAME.yaml
    if token.endswith(FILES):
        return True
    words = [p for p in parts if p != ".."]
    return len(words) > 1 and (words[0] in TOP or (words[0] in SUBPACKAGES and token.endswith("/")))


def _bases(named_in: Path) -> list[Path]:
    folder, bases = named_in.parent, [ROOT, PACKAGE]
    while folder != ROOT and ROOT in folder.parents:
        bases.append(folder)
        folder = folder.parent
    return bases


def _find(ref: str, bases: list[Path]) -> Path | None:
    ref = ref.rstrip("/")
    return next((base / ref for base in bases if (base / ref).exists()), None)


def _allowed(ref: str) -> bool:
    return any(ref.startswith(name) or ref.endswith(name) for name in ALLOWED)


def _missing_paths(named_in: Path, text: str) -> list[str]:
    tokens = [t.rstrip(".").split("#")[0] for t in TOKEN.findall(text)]
    refs = [t for t in tokens if _is_path(t) and not _allowed(t.lstrip("./"))]
    bases = _bases(named_in)
    # the folders the same text names (`formats/`, `openral_data/record/`, a named file's folder) anchor bare names
    named = [
        found for t in tokens if (t.endswith("/") or t in refs) and not t.startswith(".") and (found := _find(t, bases))
    ]
    anchors = [found if found.is_dir() else found.parent for found in named]
    tops = [ROOT / top for top in TOP]
    return [ref for ref in refs if _find(ref, [*bases, *anchors, *(tops if "/" not in ref else [])]) is None]


def _top_level_names(tree: ast.Module) -> set[str]:
    names: set[str] = set()
    for node in tree.body:
        if isinstance(node, ast.ClassDef | ast.FunctionDef | ast.AsyncFunctionDef):
            names.add(node.name)
        elif isinstance(node, ast.Assign | ast.AnnAssign):
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            names.update(t.id for t in targets if isinstance(t, ast.Name))
        elif isinstance(node, ast.Import | ast.ImportFrom):
            names.update(a.asname or a.name for a in node.names)
    return names


def _module_defines(module: str, name: str) -> bool:
    path = PACKAGE.joinpath(*module.split(".")[1:])
    source = path / "__init__.py" if path.is_dir() else path.with_suffix(".py")
    names = _top_level_names(ast.parse(source.read_text(), str(source)))
    if name in names or (path / f"{name}.py").is_file() or (path / name / "__init__.py").is_file():
        return True
    return "__getattr__" in names and hasattr(importlib.import_module(module), name)  # a lazy face: ask it


def _dotted_exists(dotted: str) -> bool:
    parts = dotted.split(".")
    for i in range(len(parts), 0, -1):
        path = ROOT.joinpath(*parts[:i])
        if path.with_suffix(".py").is_file() or (path / "__init__.py").is_file():
            return i == len(parts) or _module_defines(".".join(parts[:i]), parts[i])
    return False


def test_every_path_named_in_docstrings_comments_and_docs_exists() -> None:
    stale = sorted({f"{f.relative_to(ROOT)}: {ref}" for f, text in _texts() for ref in _missing_paths(f, text)})
    assert not stale, "named but not in the repository:\n" + "\n".join(stale)


def test_every_openral_data_name_in_docstrings_comments_and_docs_exists() -> None:
    stale = sorted(
        {
            f"{f.relative_to(ROOT)}: {name}"
            for f, text in _texts()
            for name in (m.rstrip(".") for m in DOTTED.findall(text))
            if name not in ENTRY_POINT_GROUPS and not _dotted_exists(name)
        }
    )
    assert not stale, "named but not defined:\n" + "\n".join(stale)


def test_the_package_trees_list_every_package() -> None:
    """README.md and docs/architecture.md each draw the package tree: every package of openral_data/ is in both."""
    for page in (ROOT / "README.md", ROOT / "docs" / "architecture.md"):
        text = page.read_text()
        tree = text[text.index("\nopenral_data/\n") :]
        tree = tree[: tree.index("```")]
        missing = [name for name in SUBPACKAGES if not re.search(rf"(?<![\w/]){name}/", tree)]
        assert not missing, f"{page.name}: the package tree lacks {missing}"
