"""Every exception openral-data defines, each user-facing one with a stable `code`.

A user-facing error is an `OpenralError`: the CLI prints it as one line, ``error: <message>``, and exits 2; the
message names the file (or option) and the field first (``<file>: <field>: <what>``). Anything else escaping the
CLI is a bug. Messages are for people and may be reworded; `code` is for programs and tests and does not change.

Each class has a default `code`; a raise site may pass a finer ``code=`` that extends it (``"dataset"`` ->
``"dataset.missing"``). A subclass's code extends its parent's when the parent is not `OpenralError` itself.

CODES (the class default, then the finer codes raise sites pass; docs/errors.md has the same table):

====================  ================================================================================
code                  meaning
====================  ================================================================================
error                 the base class only; never raised bare
usage                 a command-line option has a bad value or does not combine with another
config                a manifest, scene, mapping or pipeline file is invalid (names file and field)
config.checkpoint       a policy checkpoint's weights or processor state files are unusable
compat                scene, robot, rSkill (or a dataset) do not fit together; raised before running
contract              a frame broke the rSkill's state/action contract or the declared cameras
missing               an input path does not exist
output.exists         the output path already holds something; nothing is overwritten
dataset               a dataset on disk is unusable:
dataset.invalid         malformed, or not a dataset at all
dataset.incomplete      a file its metadata names is gone
dataset.mismatch        it does not match what is appended to or merged with it
dataset.unsupported     valid, but not a layout this command handles (not written by openral-data, ...)
dataset.interrupted     a commit was interrupted; run ``openral-data doctor --repair``
dataset.unsafe          a path from a file's contents leads outside its root; a control file is not a regular file
dataset.readonly        the dataset cannot be written (read-only file system or no permission); reading works
dataset.unloadable      an output lerobot 0.6.1's loader could not load; refused before it was published
dataset.busy          another live process holds the dataset's writer lock (`DatasetBusy`)
episodes              an episode selection is wrong:
episodes.syntax         not an index or a range a-b
episodes.range          outside the dataset's episodes
episodes.duplicate      an episode is listed twice
episodes.empty          the result would hold no episode
bag                   a ROS bag cannot be converted:
bag.invalid             unreadable, or not a bag of the expected kind
bag.topic               a mapped topic is not in the bag
bag.field               a mapped message field is missing or has the wrong type or length
bag.type                a mapped topic's message type or image encoding cannot serve its role
bag.empty               no frame could be filled; nothing was written
results               a results directory (policy evaluation output) is malformed
query                 DuckDB rejected a query or a setting
hub                   the Hugging Face Hub did not take a push or give a download:
hub.auth                no token, or the Hub refused it (401/403)
hub.network             the Hub could not be reached (no network, offline mode, a timeout)
hub.missing             no such dataset repo or revision (or a private one the token cannot read)
hub.refused             the Hub answered with an error (an invalid repo id, a rejected commit, ...)
replay                a dataset cannot be replayed (no initial state, no scene to rebuild, ...)
executor              a parallel recording's executor is unavailable or a worker failed
write                 writing an output failed part-way
write.disk              the disk refused a write: full, failing, read-only or over quota (`DiskError`)
write.disk.spill          frames spilled behind a slow encoder reached the spill cap (`SpillFull`)
hal                   the robot cannot do what was asked:
hal.disconnected        used before connect()
hal.connect             cannot connect to the hardware (port, bus)
hal.calibration         the motors' calibration differs from the calibration file
hal.state               the driver returned a state of the wrong shape
hal.command             an action of the wrong shape or with non-finite values
hal.camera              a camera delivered no fresh sample for too long; the episode is abandoned
hal.teleop              a teleoperation device (gamepad, SpaceMouse) is missing, unreadable or went away
hal.estop             an emergency stop is latched (`EstopLatched`)
hal.stale             the newest joint reading is older than the staleness limit (`StaleState`)
====================  ================================================================================

`EncoderError` is internal (a `RuntimeError`, not user-facing): a video encoder failed.
"""

from __future__ import annotations

import copy
import errno as _errno
import os
from collections.abc import Iterator
from pathlib import Path
from typing import Any, ClassVar, Self


def _rebuild(cls: type[OpenralError], args: tuple[Any, ...]) -> OpenralError:
    err = cls.__new__(cls)
    err.args = args
    return err


class OpenralError(Exception):
    """A user-facing error: bad input, an incompatible combination, an unusable output path."""

    default_code: ClassVar[str] = "error"

    def __init__(self, message: str, *, code: str | None = None) -> None:
        super().__init__(message)
        cls_code = type(self).default_code
        if code is not None and not code.startswith(cls_code + "."):
            raise ValueError(f"{type(self).__name__}: code {code!r} does not extend {cls_code!r}")
        self.code: str = code or cls_code

    def amended(self, message: str) -> Self:
        """The same error (class, code, facts) with a reworded message, e.g. with a note appended."""
        err = copy.copy(self)
        err.args = (message,)
        return err

    def __reduce__(self) -> tuple[Any, ...]:
        # pickled across worker processes: keep class, message, code and any typed facts without re-running __init__
        return (_rebuild, (type(self), self.args), self.__dict__)


class UsageError(OpenralError):
    """A command-line option has a bad value, or two options do not combine."""

    default_code = "usage"


class ConfigError(OpenralError):
    """A manifest or scene file is invalid. The message names the file and the field."""

    default_code = "config"


def install_hint(extra: str) -> str:
    """How to install the optional extra `extra`, both ways, for the one line that says it is missing: what a
    `pip install`-ed user types, and what a checkout's `uv` environment takes (scripts/setup.sh installs all)."""
    return f"pip install 'openral-data[{extra}]' (in a checkout: uv sync --extra {extra})"


class CompatibilityError(OpenralError):
    """Scene, robot and rSkill do not fit together; raised before the first episode."""

    default_code = "compat"


class ContractViolation(OpenralError):
    """A frame did not satisfy the rSkill's state/action contract or the declared cameras."""

    default_code = "contract"


class NotFound(OpenralError):
    """An input path given on the command line does not exist."""

    default_code = "missing"


class OutputExists(OpenralError):
    """The output path already holds something; openral-data never overwrites it."""

    default_code = "output.exists"


class DatasetError(OpenralError):
    """A dataset on disk cannot be used as it is: malformed, incomplete, or not matching what is asked of it."""

    default_code = "dataset"


class DatasetBusy(DatasetError):
    """Another live process is writing the dataset (it holds ``DATASET/.openral/lock``)."""

    default_code = "dataset.busy"

    def __init__(self, root: Path, holder: str, *, to_edit: bool = False, verb: str = "edit") -> None:
        if to_edit:  # the dataset is read, not written: `verb` it once the writer is done
            super().__init__(f"{root}: a writer is recording into this dataset ({holder}); {verb} it once it is done")
        else:
            super().__init__(f"{root}: another writer holds this dataset ({holder}); wait for it or stop it")
        self.root = root
        self.holder = holder


class SparseGap(Exception):
    """Internal, never shown: a strided decode cannot place its frames by time stamp (formats/lerobot_v3/sparse.py);
    the caller decodes the span whole instead."""


class VideoEnds(DatasetError):
    """A camera's video holds fewer frames than its episode's rows: it ends after `count` of the `n` frames."""

    default_code = "dataset.short"

    def __init__(self, path: Path, count: int, n: int) -> None:
        super().__init__(f"{path}: video ends after {count} of the episode's {n} frames")
        self.path, self.count, self.n = path, count, n


class EpisodeSelectionError(OpenralError):
    """An episode selection (``--episodes 0,3-5``) is malformed, out of range, or selects nothing usable."""

    default_code = "episodes"


class BagError(OpenralError):
    """A ROS bag cannot be read or does not carry what the mapping asks for."""

    default_code = "bag"


class ResultsError(OpenralError):
    """A results directory (policy-evaluation output) is malformed."""

    default_code = "results"


class QueryError(OpenralError):
    """DuckDB rejected a query (``--sql``, ``--by``) or a setting (``--memory-limit``)."""

    default_code = "query"


class HubError(OpenralError):
    """The Hugging Face Hub did not take a push or give a download: no token, no network, no such repo, or an error
    answer (`code` says which)."""

    default_code = "hub"


class ReplayError(OpenralError):
    """A dataset cannot be replayed: no recorded initial state, no scene to rebuild, a policy ran out of actions."""

    default_code = "replay"


class GenerateError(OpenralError):
    """`generate` cannot start (source demonstrations it cannot segment or re-target) or kept no episode."""

    default_code = "generate"


class ExecutorError(OpenralError):
    """A parallel recording's executor is unavailable or a worker failed."""

    default_code = "executor"


class WriteError(OpenralError):
    """Writing an output failed part-way (the episode in flight is discarded)."""

    default_code = "write"


DISK_ERRNOS = frozenset({_errno.ENOSPC, _errno.EIO, _errno.EROFS, _errno.EDQUOT})


def disk_errno(exc: BaseException | None) -> int | None:
    """The errno of the disk problem behind `exc` (an OSError in it or its cause/context chain), else None."""
    for link in _chain(exc):
        if isinstance(link, DiskError):
            return link.errno
        if isinstance(link, OSError) and link.errno in DISK_ERRNOS:
            return link.errno
    return None


def disk_class(exc: BaseException | None) -> type[DiskError]:
    """The class of the `DiskError` behind `exc` (`SpillFull`), to keep when it is re-raised about another path;
    `DiskError` when there is none."""
    for link in _chain(exc):
        if isinstance(link, DiskError):
            return type(link)
    return DiskError


def _chain(exc: BaseException | None) -> Iterator[BaseException]:
    """`exc`, then its cause (else context), and so on, each once."""
    seen: set[int] = set()
    while exc is not None and id(exc) not in seen:
        seen.add(id(exc))
        yield exc
        exc = exc.__cause__ or exc.__context__


class DiskError(WriteError):
    """The disk refused a write (ENOSPC, EIO, EROFS, EDQUOT) while `doing` something to the output at `path`.

    `committed`: the write failed after the commit point of an episode (its journal was durable), so the next
    `record --resume` or `doctor --repair` finishes that episode's commit instead of dropping it.
    """

    default_code = "write.disk"

    def __init__(self, path: Path, errno: int, doing: str, *, committed: bool = False) -> None:
        super().__init__(f"{path}: {disk_problem(errno)} while {doing}")
        self.path = path
        self.errno = errno
        self.doing = doing
        self.committed = committed


class SpillFull(DiskError):
    """Frames spilled to disk behind a slow encoder reached the spill cap (`WriterConfig.spill_limit_mb`; errno
    ENOSPC: the cap is the space the recording may take)."""

    default_code = "write.disk.spill"


def disk_problem(errno: int) -> str:
    """The errno's strerror as a phrase: 28 -> 'no space left on device'."""
    text = os.strerror(errno)
    return text[:1].lower() + text[1:]


class HalError(OpenralError):
    """The robot cannot do what was asked (not connected, bus fault, bad command)."""

    default_code = "hal"


class EstopLatched(HalError):
    """An emergency stop is latched: commands are refused until `reset_estop()`."""

    default_code = "hal.estop"


class StaleState(HalError):
    """The newest joint reading is older than the staleness limit."""

    default_code = "hal.stale"


class EncoderError(RuntimeError):
    """Internal: a video encoder failed or was misused. Not user-facing (a bug or a broken codec install)."""


class NotRegularFile(OSError):
    """Not user-facing: a file read by name (a JSON file) is a FIFO, a device or a folder, so reading it could
    block for ever or never end; `formats.jsonfile.read_json` turns it into a `DatasetError`."""


class RecordingInterrupted(KeyboardInterrupt):
    """Not user-facing: a Ctrl-C (or SIGTERM) that stopped `record` once its dataset folder held its settings:
    `out` is where the finished episodes are, and `record --resume --out OUT` continues it (cli/record.py)."""

    def __init__(self, out: Path) -> None:
        super().__init__(str(out))
        self.out = out
