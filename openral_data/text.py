"""Dataset text is data: `printable` makes a string from a file (a task, a feature key, an id) safe to show.

A crafted dataset may put terminal control sequences in its text (`ESC ]8;;http://evil BEL` makes a link,
`ESC [2J` clears the screen) or line breaks that forge extra output lines. Wherever such text is printed or
published (the CLI's tables, rows and error lines, the Hub card), it goes through `printable` first; the CLI
also shows it without rich markup or emoji codes (openral_data/cli/terminal.py).
"""

from __future__ import annotations

import difflib
import re
from collections.abc import Iterable, Sequence

# C0 and C1 controls, DEL, the Unicode line/paragraph separators and the bidirectional overrides (which reorder
# what a reader sees, "Trojan Source")
_CONTROL = re.compile("[\x00-\x1f\x7f-\x9f\u2028\u2029\u200e\u200f\u202a-\u202e\u2066-\u2069]")


def printable(text: str, *, keep_newlines: bool = False) -> str:
    """`text` with every control character shown as its Python escape (`\\x1b`, `\\n`, `\\u202e`), so none
    reaches a terminal or breaks a line; with `keep_newlines`, `\\n` stays (multi-line output of our own)."""

    def shown(match: re.Match[str]) -> str:
        ch = match.group()
        return ch if keep_newlines and ch == "\n" else repr(ch)[1:-1]

    return _CONTROL.sub(shown, text)


def json_escaped(text: str) -> str:
    """JSON text (from `json.dumps(..., ensure_ascii=False)`) with the control characters JSON leaves raw (C1,
    DEL, bidi overrides, line separators) written as ``\\uXXXX`` escapes: the same document, safe on a terminal.
    Outside strings JSON text holds none of them, so every one replaced lies inside a string."""
    return _CONTROL.sub(lambda m: f"\\u{ord(m.group()):04x}", text)


SHOWN = 12  # choices an "unknown name" line lists before pointing at the command that lists them all


def closest(value: str, choices: Iterable[str]) -> str | None:
    """The choice `value` most likely misspells (difflib's ratio at least 0.6), or None."""
    close = difflib.get_close_matches(value, list(choices), n=1, cutoff=0.6)
    return close[0] if close else None


def did_you_mean(value: str, choices: Iterable[str]) -> str:
    """`; did you mean 'x'?` for the closest of `choices`, or "" (to append to an error line)."""
    close = closest(value, choices)
    return "" if close is None else f"; did you mean {close!r}?"


def choices_hint(value: str, choices: Sequence[str], listing: str) -> str:
    """What follows "unknown <kind> 'value'" on an error line: `did you mean 'x'? (N in all: <listing>)` for the
    closest choice (difflib), else `valid: a, b, ...` (the first `SHOWN`, then `... (N in all: <listing>)`);
    always one line, however many choices there are. `listing` is the command that lists them all."""
    close = closest(value, choices)
    if close is not None:
        return f"did you mean {close!r}? ({len(choices)} in all: {listing})"
    shown = ", ".join(choices[:SHOWN]) or "(none)"
    return f"valid: {shown}" + (f", ... ({len(choices)} in all: {listing})" if len(choices) > SHOWN else "")
