"""Global flags anywhere on the line: `openral-data info D -v` is `openral-data -v info D` (docs/cli.md).

The root group's options (`-v/-vv`, `-q`, `--log-format`, `--scenes-dir`, ...) are parsed by the root before
the command runs; `RootGroup` moves those that follow the command name in front of it. A token is moved only
where the command being parsed would not read it itself: not after `--`, not as the value of one of the
command's options (`--sql -q`), and not when the command has an option of that name.

`-v` counts (`-v` INFO, `-vv` DEBUG): `-v 2` is refused with that hint rather than reading `2` as an argument.

The root group also gives the editing commands (`episodes`, `videos`, `tasks`, `features`, `stats recompute`) and
`doctor --deep` their progress bar (episodes written, video files decoded; `formats.progress`), on stderr; none
with `-q`, `--json` or no terminal. `--json` anywhere before `--` turns every progress bar off
(`terminal.json_output`).
"""

from __future__ import annotations

import itertools
import re
from typing import Any

from openral_data.cli import terminal
from openral_data.cli.help import PlainFlagsGroup
from openral_data.cli.terminal import LazyBar
from openral_data.errors import UsageError

_VERBOSE = re.compile(r"-v+")


def _names(command: Any) -> set[str]:
    return {name for p in command.params for name in (*p.opts, *p.secondary_opts)}


def _takes_value(command: Any, token: str) -> bool:
    """Whether `token` is an option of `command` whose value is the next token."""
    for p in command.params:
        if token in p.opts and getattr(p, "param_type_name", "") == "option":
            return not (getattr(p, "is_flag", False) or getattr(p, "count", False))
    return False


def _subcommand(group: Any, token: str) -> Any:
    """The command `token` names in `group`, or None (for a group with a default command: that one)."""
    commands = getattr(group, "commands", None)
    if commands is None:
        return None
    if token in commands:
        return commands[token]
    default = getattr(group, "default", None)
    return commands.get(default) if isinstance(default, str) else None


def _check_count(args: list[str]) -> None:
    for flag, after in itertools.pairwise(args):
        if flag == "--":
            return
        if (flag == "--verbose" or _VERBOSE.fullmatch(flag)) and after.isdigit():
            raise UsageError(f"{flag} {after}: -v counts and takes no number: -v is INFO, -vv DEBUG")


def hoist(root: Any, args: list[str]) -> list[str]:
    """`args` with the root's options that come after the command name moved before it (see the module doc)."""
    _check_count(args)
    globals_ = _names(root)
    moved: list[str] = []
    kept: list[str] = []
    command = root
    i = 0
    while i < len(args):
        token = args[i]
        name = token.split("=", 1)[0]
        if token == "--":
            kept.extend(args[i:])
            break
        is_global = name in globals_ or bool(_VERBOSE.fullmatch(token))
        if command is not root and is_global and name not in _names(command):
            take = 2 if "=" not in token and _takes_value(root, name) else 1
            moved.extend(args[i : i + take])
            i += take
            continue
        if token.startswith("-") and "=" not in token and _takes_value(command, token):
            kept.extend(args[i : i + 2])
            i += 2
            continue
        if not token.startswith("-"):
            command = _subcommand(command, token) or command
        kept.append(token)
        i += 1
    return moved + kept


def _command_name(root: Any, args: list[str]) -> str | None:
    """The command `args` (root options first, as `hoist` leaves them) run, or None."""
    i = 0
    while i < len(args) and args[i].startswith("-") and args[i] != "--":
        i += 2 if "=" not in args[i] and _takes_value(root, args[i]) else 1
    return args[i] if i < len(args) else None


# the commands whose long loops report `formats.progress`, and what their bar says
EDITING = ("episodes", "videos", "tasks", "features", "stats")  # rewrite a dataset
BARS = {name: ("writing", "episodes") for name in EDITING} | {"doctor": ("decoding", "video files")}


class RootGroup(PlainFlagsGroup):
    """The `openral-data` group: its options are also taken after the command name (`hoist`); a command with
    long loops shows their progress (`BARS`, `formats.progress`)."""

    def parse_args(self, ctx: Any, args: list[str]) -> list[str]:
        hoisted = hoist(self, args)
        parsed: list[str] = super().parse_args(ctx, hoisted)
        name = _command_name(self, hoisted)
        scripted = "--json" in itertools.takewhile(lambda token: token != "--", hoisted)
        terminal.json_output = scripted  # every progress bar stays off under --json (docs/scripting.md)
        ctx.meta["openral.bar"] = BARS.get(name or "") if not scripted else None
        return parsed

    def invoke(self, ctx: Any) -> Any:
        try:
            return self._invoke_with_bar(ctx)
        finally:  # an in-process caller's next run starts as a fresh process would (no bar off from this one's)
            terminal.json_output = False
            terminal.quiet = False  # `-q`, set by the root callback (logs.py)

    def _invoke_with_bar(self, ctx: Any) -> Any:
        labels = ctx.meta.get("openral.bar")
        if labels is None:
            return super().invoke(ctx)
        from openral_data.formats.progress import PROGRESS

        bar = LazyBar(*labels)
        token = PROGRESS.set(bar)
        try:
            return super().invoke(ctx)
        finally:
            PROGRESS.reset(token)
            bar.close()
