"""errors.py is the one home of exceptions, and every user-facing error carries a stable, distinct code."""

from __future__ import annotations

import ast
import builtins
import errno
import pickle
import re
from pathlib import Path

import pytest

import openral_data
from openral_data import errors
from openral_data.errors import DatasetBusy, DatasetError, OpenralError, UsageError

PACKAGE = Path(openral_data.__file__).parent
ERRORS = PACKAGE / "errors.py"
BUILTIN_EXCEPTIONS = {
    name
    for name in dir(builtins)
    if isinstance(getattr(builtins, name), type) and issubclass(getattr(builtins, name), BaseException)
}
CODE = re.compile(r"^[a-z]+(\.[a-z]+)*$")


def _subclasses(cls: type[OpenralError]) -> list[type[OpenralError]]:
    found: list[type[OpenralError]] = []
    for sub in cls.__subclasses__():
        found += [sub, *_subclasses(sub)]
    return found


def _base_name(node: ast.expr) -> str | None:
    if isinstance(node, ast.Name):
        return node.id
    if isinstance(node, ast.Attribute):
        return node.attr
    return None


def _modules() -> list[tuple[Path, ast.Module]]:
    return [(path, ast.parse(path.read_text(), str(path))) for path in sorted(PACKAGE.rglob("*.py"))]


def test_every_error_class_has_a_distinct_code() -> None:
    classes: list[type[OpenralError]] = [OpenralError, *_subclasses(OpenralError)]
    codes = [cls.default_code for cls in classes]
    assert all(code and CODE.match(code) for code in codes), codes
    assert len(set(codes)) == len(codes), codes
    for cls in classes:
        assert cls.__module__ == "openral_data.errors", cls
        parent = cls.__mro__[1]
        if parent is not OpenralError and issubclass(parent, OpenralError):
            assert cls.default_code.startswith(parent.default_code + "."), (cls, parent)


def test_errors_py_is_the_only_module_defining_exceptions() -> None:
    tree = ast.parse(ERRORS.read_text())
    local = {node.name for node in ast.walk(tree) if isinstance(node, ast.ClassDef)}
    exception_names = BUILTIN_EXCEPTIONS | local
    offenders = []
    for path, module in _modules():
        if path == ERRORS:
            continue
        for node in ast.walk(module):
            if isinstance(node, ast.ClassDef) and any(_base_name(b) in exception_names for b in node.bases):
                offenders.append(f"{path.relative_to(PACKAGE)}:{node.lineno} {node.name}")
    assert offenders == []


def test_no_module_raises_the_bare_base_class() -> None:
    bare = []
    for path, module in _modules():
        for node in ast.walk(module):
            if isinstance(node, ast.Call) and _base_name(node.func) == "OpenralError":
                bare.append(f"{path.relative_to(PACKAGE)}:{node.lineno}")
    assert bare == []


def test_every_raise_site_code_extends_its_class_code() -> None:
    classes = {cls.__name__: cls for cls in _subclasses(OpenralError)}
    wrong, seen = [], 0
    for path, module in _modules():
        for node in ast.walk(module):
            if not (isinstance(node, ast.Call) and _base_name(node.func) in classes):
                continue
            for kw in node.keywords:
                if kw.arg == "code":
                    seen += 1
                    prefix = classes[str(_base_name(node.func))].default_code + "."
                    if not (isinstance(kw.value, ast.Constant) and str(kw.value.value).startswith(prefix)):
                        wrong.append(f"{path.relative_to(PACKAGE)}:{node.lineno}")
    assert seen and wrong == []


def test_docs_list_every_code() -> None:
    docs = (PACKAGE.parent / "docs" / "errors.md").read_text()
    codes = {cls.default_code for cls in _subclasses(OpenralError)}
    for _, module in _modules():
        codes |= {
            str(kw.value.value)
            for node in ast.walk(module)
            if isinstance(node, ast.Call)
            for kw in node.keywords
            if kw.arg == "code" and isinstance(kw.value, ast.Constant)
        }
    assert sorted(code for code in codes if f"| `{code}` |" not in docs) == []


def test_a_finer_code_extends_the_class_code() -> None:
    assert DatasetError("x").code == "dataset"
    assert DatasetError("x", code="dataset.invalid").code == "dataset.invalid"
    with pytest.raises(ValueError, match="does not extend"):  # the wording is the point: a programming error
        DatasetError("x", code="datasetx")
    with pytest.raises(ValueError, match="does not extend"):
        UsageError("x", code="config")


def test_amended_and_pickled_errors_keep_class_code_and_facts() -> None:
    busy = DatasetBusy(Path("/d"), "pid 7, record, since now")
    assert str(busy) == "/d: another writer holds this dataset (pid 7, record, since now); wait for it or stop it"
    noted = busy.amended(f"{busy} (2 finished episode(s) kept in /d)")
    assert type(noted) is DatasetBusy and noted.code == "dataset.busy" and noted.root == Path("/d")
    assert str(noted).endswith("(2 finished episode(s) kept in /d)") and str(busy).endswith("stop it")
    for err in (busy, DatasetError("m", code="dataset.mismatch"), errors.StaleState("s")):
        back = pickle.loads(pickle.dumps(err))
        assert (type(back), back.code, str(back), back.__dict__) == (type(err), err.code, str(err), err.__dict__)


@pytest.mark.parametrize(
    ("code", "phrase"),
    [
        (errno.ENOSPC, "no space left on device"),
        (errno.EIO, "input/output error"),
        (errno.EROFS, "read-only file system"),
        (errno.EDQUOT, "disk quota exceeded"),
    ],
)
def test_disk_errors_name_the_problem_and_are_found_behind_other_errors(code: int, phrase: str) -> None:
    err = errors.DiskError(Path("/d"), code, "committing episode 3", committed=True)
    assert str(err) == f"/d: {phrase} while committing episode 3"
    assert err.code == "write.disk" and isinstance(err, errors.WriteError)
    back = pickle.loads(pickle.dumps(err))
    assert (type(back), str(back), back.__dict__) == (type(err), str(err), err.__dict__)
    try:
        try:
            raise OSError(code, "x")
        except OSError as exc:
            raise RuntimeError("encoder failed") from exc
    except RuntimeError as wrapped:
        assert errors.disk_errno(wrapped) == code
    assert errors.disk_errno(OSError(errno.EACCES, "x")) is None and errors.disk_errno(ValueError()) is None
