"""`--help` tables: a boolean flag or a count (`-v/-vv`) shows no value type (typer's rich help prints `<bool>`
for every flag, `--help` included, and `<int>` for a count, although neither takes a value). `plain_flags(app)`
applies this to every command and sub-app, and gives each command and sub-app a one-line summary for its parent's
command list: the first sentence of its help (rich help would keep the docstring's line breaks, breaking
sentences mid-way at any width)."""

from __future__ import annotations

import inspect
import re
from typing import Any

import typer
from typer.core import TyperCommand, TyperGroup, TyperOption
from typer.models import DefaultPlaceholder


def _without_flag_metavar(params: list[Any]) -> list[Any]:
    """`params`, each boolean flag and count given an empty metavar (what the help's type column shows for it)."""
    for param in params:
        if isinstance(param, TyperOption) and (param.is_bool_flag or param.count) and param.metavar is None:
            param.metavar = ""
    return params


class PlainFlagsCommand(TyperCommand):
    """A command whose help shows no `<bool>` for its flags."""

    def get_params(self, ctx: Any) -> list[Any]:
        return _without_flag_metavar(super().get_params(ctx))


class PlainFlagsGroup(TyperGroup):
    """A command group whose help shows no `<bool>` for its flags."""

    def get_params(self, ctx: Any) -> list[Any]:
        return _without_flag_metavar(super().get_params(ctx))


_SENTENCE_END = re.compile(r"(?<=[.!?])\s+(?=[A-Z`(])")


def summary(text: str | None) -> str | None:
    """The first sentence of `text`'s first paragraph on one line (None when there is no text)."""
    if not text:
        return None
    first = " ".join(inspect.cleandoc(text).split("\n\n")[0].split())
    return _SENTENCE_END.split(first, maxsplit=1)[0]


def plain_flags(app: typer.Typer) -> None:
    """Build `app`, its commands and its sub-apps (recursively) with the classes above; call it once every command
    is registered. A command or group that names its own class keeps it."""
    if isinstance(app.info.cls, DefaultPlaceholder) or app.info.cls in (None, TyperGroup):
        app.info.cls = PlainFlagsGroup
    for command in app.registered_commands:
        if command.cls in (None, TyperCommand):  # typer records its default class, not None
            command.cls = PlainFlagsCommand
        if command.short_help is None:
            command.short_help = summary(command.help or inspect.getdoc(command.callback))
    for group in app.registered_groups:
        if group.typer_instance is not None:
            plain_flags(group.typer_instance)
            own = [h for h in (group.short_help, group.help, group.typer_instance.info.help) if isinstance(h, str)]
            group.short_help = summary(own[0]) if own else None
