"""The argument parser's errors in the house form: `--codec: 'h265x' is not one of 'av1', 'h264'`.

typer checks a typed option (a `Literal`, a path, a number) with pydantic; its message then reads
`Invalid value for '--codec': Value error, ...`. `parser_message` names the option (or argument) as the error's
field and keeps what pydantic said without its wording (`Value error, `, the trailing full stop), one line.
"""

from __future__ import annotations

from typing import Any


def _field(param: Any) -> str:
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
        what = "; ".join(plain_message(e["msg"]).rstrip(".") for e in cause.errors())
        return f"{_field(param)}: {what}"
    message: str = getattr(exc, "format_message", exc.__str__)()
    return message
