"""The corpus's cases: a case builds one bad input in a fresh workspace and names the command line that must
refuse it (see the package); each module of the package adds its cases with `case` when it is imported."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from tests.support.malformed import Workspace

Build = Callable[[Workspace], list[str]]


@dataclass(frozen=True)
class Case:
    id: str
    build: Build
    names: str
    new: tuple[str, ...] = ()


CASES: list[Case] = []


def case(id: str, build: Build, names: str, new: tuple[str, ...] = ()) -> None:
    assert all(c.id != id for c in CASES), id
    CASES.append(Case(id, build, names, new))
