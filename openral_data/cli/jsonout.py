"""`--json`: one JSON document on stdout, the same shape for every command (docs/scripting.md)."""

from __future__ import annotations

import json
import math
import sys
from collections.abc import Mapping
from pathlib import Path
from typing import Annotated

import typer

from openral_data.text import json_escaped
from openral_data.version import __version__


def print_json(command: str, doc: Mapping[str, object]) -> None:
    """Write `{"command": command, "version": <package version>, **doc}` to stdout as ONE line of JSON.

    Keys keep the order given (`command`, `version`, then the command's fields as docs/scripting.md lists them);
    non-ASCII stays as is (UTF-8), control characters are escaped (`text.json_escaped`); a path becomes its
    string; a float is `rounded` (a non-finite one is null: JSON has no NaN); any other value (a date from a
    `stats --sql` result) its text.
    Nothing else may be written to stdout by a `--json` run: progress and messages go to stderr.
    """
    full = {"command": command, "version": __version__, **doc}
    text = json_escaped(json.dumps(_plain(full), ensure_ascii=False, allow_nan=False))
    sys.stdout.write(text + "\n")
    sys.stdout.flush()


SIGNIFICANT = 12  # digits a float keeps: 2.4000000000000004 (arithmetic noise) is 2.4, 1.5e-08 stays 1.5e-08


def rounded(value: float) -> float | None:
    """`value` to `SIGNIFICANT` significant digits (its meaning, without the last bits of arithmetic noise); None
    for a non-finite float (JSON has no NaN). The one rounding of every float in every `--json` document."""
    return float(f"{value:.{SIGNIFICANT}g}") if math.isfinite(value) else None


def _plain(value: object) -> object:
    if isinstance(value, float):
        return rounded(value)
    if isinstance(value, Path):
        return str(value)
    if isinstance(value, Mapping):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_plain(v) for v in value]
    if value is None or isinstance(value, str | int):
        return value
    return str(value)  # a date, a Decimal, a UUID (from a `stats --sql` result): its text


JsonFlag = Annotated[
    bool, typer.Option("--json", help="print one JSON document on stdout instead (fields: docs/scripting.md)")
]
