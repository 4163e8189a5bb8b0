"""The argument parser's errors in the house form: `--codec: 'h265x' is not one of 'av1', 'h264'`.

typer checks a typed option (a `Literal`, a path, a number) with pydantic; its message then reads
`Invalid value for '--codec': Value error, ...`. `parser_message` names the option (or argument) as the error's
field and keeps what pydantic said without its wording (`Value error, `, the trailing full stop), one line. A
value that is not one of the choices gets the closest choice suggested (`did you mean 'scenes'?`), and a bad
positional argument is named by its command (`list: 'scnes' is not one of ...`), not by an internal name.
"""

from __future__ import annotations

import difflib
import re
from typing import Any

_NOT_ONE_OF = re.compile(r"'([^']*)' is not one of (.+)$")


def _field(param: Any, ctx: Any = None) -> str:
    if getattr(param, "param_type_name", "") == "argument" and ctx is not None:
        command = " ".join(str(ctx.command_path).split()[1:])  # without the program's name
        if command:
            return command
    opts = [o for o in getattr(param, "opts", ()) if o.startswith("--")] or list(getattr(param, "opts", ()))
    if getattr(param, "param_type_name", "") == "option" and opts:
        return str(opts[0])
    return str(getattr(param, "human_readable_name", "") or getattr(param, "name", "") or "argument")


def parser_message(exc: BaseException) -> str:
    """What the CLI prints after `error: ` for a parser error `exc` (click's UsageError family, as typer raises)."""
    from pydantic import ValidationError

    from openral_data.schemas.base import plain_message

    cause, param = exc.__cause__, getattr(exc, "param", None)
    if isinstance(cause, ValidationError) and param is not None:
        what = "; ".join(_suggest(plain_message(e["msg"]).rstrip(".")) for e in cause.errors())
        return f"{_field(param, getattr(exc, 'ctx', None))}: {what}"
    message: str = getattr(exc, "format_message", exc.__str__)()
    return message


def _suggest(what: str) -> str:
    """`'scnes' is not one of 'all', 'scenes', ...` with `; did you mean 'scenes'?` when a choice is close."""
    found = _NOT_ONE_OF.search(what)
    if found is None:
        return what
    choices = re.findall(r"'([^']*)'", found.group(2)) or [c.strip() for c in found.group(2).split(",")]
    close = difflib.get_close_matches(found.group(1), choices, n=1)
    return what + (f"; did you mean '{close[0]}'?" if close else "")
