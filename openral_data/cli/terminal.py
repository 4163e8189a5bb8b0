"""What every command prints with: the two consoles, the progress bar and the `key: value` summary rows.

Dataset text is data (docs/threat-model.md): the consoles never turn `:x:` into an emoji, lines and rows are
printed without rich markup, and every control character in them is shown escaped (`openral_data.text.printable`);
a table cell holding dataset text is a `shown(...)` Text, never markup.
"""

from __future__ import annotations

import os
import textwrap

from rich.console import Console
from rich.errors import LiveError
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TaskID, TextColumn, TimeElapsedColumn
from rich.text import Text

from openral_data.text import printable

console = Console(emoji=False)
err_console = Console(stderr=True, emoji=False)
# what a Ctrl-C during `record` leaves (sim and --hal alike; see openral_data/record/session.py)
INTERRUPTED_RECORDING = "interrupted: the episode in flight was discarded, finished episodes are kept"
quiet = False  # `-q`: no progress bar (set by the root callback, see openral_data/cli/logs.py)
# `--json`: no progress bar either, the run is a script's (set by the root group, openral_data/cli/globalflags.py)
json_output = False


def progress_bar(what: str, unit: str, *fields: str) -> Progress:
    """`what [bar] done/total unit fields... elapsed` on stderr; silent when stderr is not a terminal, with `-q` or
    under `--json`.

    `what` is rich markup (shown bold); each of `fields` is a column template such as "{task.fields[frames]}".
    """
    return Progress(
        TextColumn(f"[bold]{what}"),
        BarColumn(),
        MofNCompleteColumn(),
        TextColumn(unit),
        *(TextColumn(f) for f in fields),
        TimeElapsedColumn(),
        console=err_console,
        disable=quiet or json_output or not err_console.is_terminal,
    )


class LazyBar:
    """A `progress_bar` that appears at the first `(done, total)` it is given (a command that turns out to have
    nothing long to do shows none); silent where `progress_bar` is, and when another live display (a command's
    own bar) is already on screen. `close()` takes it down."""

    def __init__(self, what: str, unit: str) -> None:
        self.what, self.unit = what, unit
        self.bar: Progress | None = None
        self.task: TaskID | None = None
        self.off = False

    def __call__(self, done: int, total: int) -> None:
        if self.off:
            return
        if self.bar is None or self.task is None:
            bar = progress_bar(self.what, self.unit)
            try:
                bar.start()
            except LiveError:  # a command's own progress bar is showing: that one speaks
                self.off = True
                return
            self.bar, self.task = bar, bar.add_task(self.what, total=total)
        self.bar.update(self.task, completed=done, total=total)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.stop()


def _wrap_width() -> int | None:
    """The width rows wrap at: the terminal's, or `$COLUMNS` when piped; None (never wrapped) when piped without
    it (a log keeps each row on one greppable line)."""
    if console.is_terminal:
        return console.width
    columns = os.environ.get("COLUMNS", "")
    return int(columns) if columns.isdigit() else None


def print_rows(title: str, rows: list[tuple[str, str]]) -> None:
    """`key  value` lines, never truncated: a value longer than the terminal's width continues on the next lines
    under itself (wrapped between words; a path longer than the line stays whole); piped, one line per row."""
    width = max(len(k) for k, _ in rows)
    wrap = _wrap_width()
    console.print(printable(title), markup=False, highlight=False, soft_wrap=True)
    for key, value in rows:
        lead = f"  {key:<{width}}  "
        room = (wrap or 0) - len(lead)
        text = printable(value)
        lines = textwrap.wrap(text, room, break_long_words=False, break_on_hyphens=False) if room >= 20 else []
        for i, line in enumerate(lines or [text]):
            console.print((lead if i == 0 else " " * len(lead)) + line, markup=False, highlight=False, soft_wrap=True)


def print_summary(title: str, rows: list[tuple[str, str]]) -> None:
    """A command's closing summary (what it wrote, how fast): `print_rows`, silent under `-q`."""
    if not quiet:
        print_rows(title, rows)


def print_done(text: str) -> None:
    """A one-line closing summary (`trimmed: OUT  episodes 3  frames 120`): silent under `-q`."""
    if not quiet:
        print_line(text)


def print_line(text: str, *, err: bool = False) -> None:
    """One line as given: no markup, no highlighting, never wrapped at the terminal width (a long dataset path
    piped to a log or a test must not split the line); control characters but `\\n` shown escaped."""
    (err_console if err else console).print(
        printable(text, keep_newlines=True), markup=False, highlight=False, soft_wrap=True
    )


def shown(text: str) -> Text:
    """`text` (a dataset's, a user's) as a table cell or header: literal, no markup, no emoji, controls escaped."""
    return Text(printable(text))
