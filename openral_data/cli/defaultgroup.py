"""A command group with a default subcommand: `openral-data stats PATH…` runs `stats report PATH…`, while
`openral-data stats recompute DATASET` runs the subcommand. A first argument that names no subcommand (a path,
an option, `--help`) is routed to the default one, so `stats --help` is the report's help (which names the other
subcommands); a path that is literally a subcommand's name is reached as `./NAME`. Without arguments the group's
own help lists its subcommands."""

from __future__ import annotations

from typing import Any

from openral_data.cli.help import PlainFlagsGroup


class DefaultCommandGroup(PlainFlagsGroup):
    """A group whose arguments go to its `default` subcommand unless the first one names a subcommand."""

    default = "report"

    def parse_args(self, ctx: Any, args: list[str]) -> list[str]:
        if args and args[0] not in self.commands:
            args = [self.default, *args]
        parsed: list[str] = super().parse_args(ctx, args)
        return parsed
