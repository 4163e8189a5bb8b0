"""What a dataset command takes, declared once where the command is defined: `@takes("dataset", ...)` on its
function. `download.dataset_commands(app)` reads these declarations when the app is built: it adds
`--download/--revision/--include` to each command (docs/hub.md#downloading-a-dataset---download) and reads a
LeRobot v2.x dataset as the declaration says (docs/upgrade.md#other-commands-on-v2x-datasets). A new dataset
command is one function with its `@takes(...)`; nothing else lists it.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Literal, TypeVar

# how a LeRobot v2.x dataset is read: "in place" (`formats.dataset` reads v2.x as it is), "upgrade" (through a
# temporary v3.0 upgrade, `legacy.read_as_v3`), "refused" (the command says to upgrade first)
V2 = Literal["in place", "upgrade", "refused"]
# what the command writes: nothing, a new dataset (or file), or a new dataset or DATASET itself (`--in-place`)
Writes = Literal["nothing", "new", "new or in place"]
# how a parameter holds episode numbers the user types: `0,3,5-7` (`episodes.renumber_list`), `EP:START-END,...`
# (`edit.trim.renumber_frames`) or `NAME=0,3,NAME=5-7` (`edit.splits.renumber_spec`)
Numbers = Literal["list", "frames", "spec"]
F = TypeVar("F", bound=Callable[..., Any])
_ATTR = "__openral_takes__"


@dataclass(frozen=True)
class Takes:
    """A dataset command's declaration (see the module docstring)."""

    param: str  # the parameter naming the dataset(s): one path or repo id, or a list of them
    pixels: bool  # reads the cameras: `--download` fetches videos/ too
    v2: V2
    writes: Writes = "nothing"
    episodes: tuple[tuple[str, Numbers], ...] = ()  # parameters holding episode numbers, and their syntax
    download: bool = True  # takes --download/--revision/--include (`push` does not: its --revision is its branch)


def takes(
    param: str,
    *,
    pixels: bool,
    v2: V2,
    writes: Writes = "nothing",
    episodes: dict[str, Numbers] | None = None,
    download: bool = True,
) -> Callable[[F], F]:
    """Declare what the decorated command takes (the function itself is returned unchanged)."""
    declaration = Takes(param, pixels, v2, writes, tuple((episodes or {}).items()), download)

    def declare(command: F) -> F:
        setattr(command, _ATTR, declaration)
        return command

    return declare


def declared(command: Callable[..., Any] | None) -> Takes | None:
    """The declaration `@takes` put on `command`, or None (not a dataset command)."""
    found = getattr(command, _ATTR, None)
    return found if isinstance(found, Takes) else None
