"""A typer command whose options are declared as the fields of a frozen dataclass, and handed to it as one
object: a command with many options keeps their declarations (type, help, default) in one place and its body short.
"""

from __future__ import annotations

import dataclasses
import inspect
from collections.abc import Callable
from typing import TYPE_CHECKING, Any, get_type_hints

import typer

if TYPE_CHECKING:
    from _typeshed import DataclassInstance


def flags_command[F: DataclassInstance](
    flags: type[F],
) -> Callable[[Callable[[typer.Context, F], None]], Callable[..., None]]:
    """`@flags_command(Flags)` over `def cmd(ctx, flags: Flags)`: typer sees `cmd(ctx, <every field of Flags>)`,
    in the fields' order (the `--help` order), each `Annotated[type, typer.Option(...)]` with its default."""
    hints = get_type_hints(flags, include_extras=True)
    kw = inspect.Parameter.KEYWORD_ONLY
    options = [
        inspect.Parameter(f.name, kw, default=f.default, annotation=hints[f.name]) for f in dataclasses.fields(flags)
    ]
    ctx = inspect.Parameter("ctx", inspect.Parameter.POSITIONAL_OR_KEYWORD, annotation=typer.Context)

    def command(body: Callable[[typer.Context, F], None]) -> Callable[..., None]:
        def run(ctx: typer.Context, **given: Any) -> None:
            body(ctx, flags(**given))

        run.__name__, run.__qualname__, run.__doc__ = body.__name__, body.__qualname__, body.__doc__
        run.__module__ = body.__module__
        run.__signature__ = inspect.Signature([ctx, *options])  # type: ignore[attr-defined]
        run.__annotations__ = {p.name: p.annotation for p in [ctx, *options]}
        return run

    return command
