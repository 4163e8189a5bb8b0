"""Which options the user gave: the parser's own parameter source, never a comparison with a copied default."""

from __future__ import annotations

import typer


def given(ctx: typer.Context) -> frozenset[str]:
    """The parameter names of `ctx`'s command that came from the command line (a default repeated on the command
    line counts as given)."""
    # typer vendors click privately, so the source is compared by its name (`ParameterSource.COMMANDLINE`)
    return frozenset(
        name for name in ctx.params if getattr(ctx.get_parameter_source(name), "name", "") == "COMMANDLINE"
    )
