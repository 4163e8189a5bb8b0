"""Commands imported when they are looked up: the root group knows every command's name and where it is defined
(`COMMANDS` in `cli/app.py`), and imports a command's module only when the command line names it (or `--help`
lists them all). `openral-data list` then pays for `list`, not for `record`, `convert` and `browse` too.

A command is built exactly as it would be in one big app: a one-command Typer app, its `@takes` declarations
applied (`dataset_commands`) and its help classes set (`plain_flags`), prepared once per process, then built into
a click command the way typer builds a group's commands.
"""

from __future__ import annotations

import importlib
from collections.abc import Iterator, MutableMapping
from typing import Any

import typer

from openral_data.cli.download import dataset_commands
from openral_data.cli.help import plain_flags

# name -> the prepared one-command app (prepared once: `dataset_commands` wraps the callbacks it is given)
_PREPARED: dict[str, typer.Typer] = {}


def _prepared(name: str, module: str, attribute: str) -> typer.Typer:
    if name not in _PREPARED:
        target = getattr(importlib.import_module(module), attribute)
        app = typer.Typer(add_completion=False, pretty_exceptions_enable=False)
        if isinstance(target, typer.Typer):
            app.add_typer(target, name=name)
        else:
            app.command(name)(target)
        dataset_commands(app)
        plain_flags(app)
        _PREPARED[name] = app
    return _PREPARED[name]


class LazyCommands(MutableMapping[str, Any]):
    """A group's commands by name: `table` says where each is (`name -> (module, attribute)`: a command function
    or a sub-app); looking one up imports and builds it (once per mapping). Membership, iteration and `len` never
    import anything."""

    def __init__(self, table: dict[str, tuple[str, str]]) -> None:
        self._table = dict(table)
        self._built: dict[str, Any] = {}

    def __getitem__(self, name: str) -> Any:
        if name not in self._built:
            if name not in self._table:
                raise KeyError(name)
            group = typer.main.get_group(_prepared(name, *self._table[name]))
            self._built[name] = group.commands[name]
        return self._built[name]

    def __contains__(self, name: object) -> bool:
        return name in self._table or name in self._built

    def __setitem__(self, name: str, command: Any) -> None:
        self._built[name] = command

    def __delitem__(self, name: str) -> None:
        if name not in self:
            raise KeyError(name)
        self._table.pop(name, None)
        self._built.pop(name, None)

    def __iter__(self) -> Iterator[str]:
        return iter([*self._table, *(name for name in self._built if name not in self._table)])

    def __len__(self) -> int:
        return len(set(self._table) | set(self._built))
