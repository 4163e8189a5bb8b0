"""`-v/-q/--log-format`: where the package's `logging` records go (docs/cli.md).

The lower layers only log (`logging.getLogger(__name__)`, structured fields in `extra=`); this module is the one
place that decides how. Records of the `openral_data` loggers go to stderr (stdout stays the command's output or
its `--json` document): through rich on a terminal, as plain `time level logger: message key=value` lines
otherwise, or as one JSON object per line with `--log-format json`. The level is WARNING by default and with
`-q` (which also hides the progress bar), INFO with `-v`, DEBUG with `-vv`.
"""

from __future__ import annotations

import json
import logging
import sys
from datetime import UTC, datetime
from enum import StrEnum

from rich.logging import RichHandler

from openral_data.cli import terminal
from openral_data.cli.terminal import err_console
from openral_data.text import printable

PACKAGE = "openral_data"
# the attributes every LogRecord has: anything else on a record came from `extra=`
_STANDARD = set(logging.LogRecord("", 0, "", 0, "", None, None).__dict__) | {"message", "asctime", "taskName"}


class LogFormat(StrEnum):
    text = "text"
    json = "json"


def fields(record: logging.LogRecord) -> dict[str, object]:
    """The structured fields a record was given with `extra=`, in the order given."""
    return {k: v for k, v in record.__dict__.items() if k not in _STANDARD and not k.startswith("_")}


class JsonFormatter(logging.Formatter):
    """One JSON object per record: `time` (UTC, ISO 8601), `level`, `logger`, `message`, then its `extra=` fields."""

    def format(self, record: logging.LogRecord) -> str:
        doc: dict[str, object] = {
            "time": datetime.fromtimestamp(record.created, UTC).isoformat(timespec="milliseconds"),
            "level": record.levelname,
            "logger": record.name,
            "message": record.getMessage(),
            **fields(record),
        }
        if record.exc_info:
            doc["exc_info"] = self.formatException(record.exc_info)
        return json.dumps(doc, ensure_ascii=False, default=str)


class TextFormatter(logging.Formatter):
    """`2026-01-01T12:00:00.000Z INFO openral_data.record.sim: message key=value ...`, one line per record."""

    def format(self, record: logging.LogRecord) -> str:
        stamp = datetime.fromtimestamp(record.created, UTC).isoformat(timespec="milliseconds").replace("+00:00", "Z")
        extra = "".join(f" {k}={v}" for k, v in fields(record).items())
        text = f"{stamp} {record.levelname} {record.name}: {record.getMessage()}{extra}"
        return printable(" ".join(text.splitlines()))


class PrintableFormatter(logging.Formatter):
    """The rich handler's message, control characters (from dataset text a message quotes) shown escaped."""

    def format(self, record: logging.LogRecord) -> str:
        return printable(super().format(record), keep_newlines=True)


def level_for(verbose: int, quiet: bool) -> int:
    if quiet:
        return logging.WARNING
    return {0: logging.WARNING, 1: logging.INFO}.get(verbose, logging.DEBUG)


def configure(verbose: int, quiet: bool, log_format: LogFormat) -> None:
    """Send the package's log records to stderr at the level `-v`/`-q` ask for, in `log_format`; `-q` also hides
    the progress bar.

    Called once per command (the root callback); calling it again replaces the handler it installed.
    """
    logger = logging.getLogger(PACKAGE)
    for old in list(logger.handlers):
        logger.removeHandler(old)
    handler: logging.Handler
    if log_format is LogFormat.json:
        handler = logging.StreamHandler(sys.stderr)
        handler.setFormatter(JsonFormatter())
    elif err_console.is_terminal:
        handler = RichHandler(console=err_console, show_path=False, markup=False, rich_tracebacks=False)
        handler.setFormatter(PrintableFormatter())
    else:
        handler = logging.StreamHandler(sys.stderr)
        handler.setFormatter(TextFormatter())
    logger.addHandler(handler)
    logger.setLevel(level_for(verbose, quiet))
    logger.propagate = False  # never twice (a library that configures the root logger)
    terminal.quiet = quiet
