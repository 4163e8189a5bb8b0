"""Episode commits behind a real-time recording (`WriterConfig.background`): the recording hands a finished episode
over and starts the next at once, while one committer thread waits for the episode's videos (its encoders flushed,
its spilled frames encoded) and commits it, episodes strictly in order, each exactly as `end_episode` commits one
(temp files, journal, info.json last: `writer`). A kill during a background commit is a kill during a commit:
`recovery.recover` finishes or undoes it, the episodes before it stay committed, and the episode being recorded
meanwhile is staged files for the quarantine.

The first failure stops the committing: later episodes are not committed (their videos are deleted) and the
failure is raised on the recording's next `begin_episode`, `end_episode` or `close` (`raise_failed`).
"""

from __future__ import annotations

import queue
import threading
from collections.abc import Callable, Mapping
from pathlib import Path

from openral_data.errors import disk_class, disk_errno
from openral_data.formats.lerobot_v3.video import EncodedEpisode, EncodeJob, EncoderWorker


class Committer:
    """One thread running the commits handed to `submit`, in order; `drain` waits until all are done."""

    def __init__(self) -> None:
        self._q: queue.Queue[Callable[[], object] | None] = queue.Queue()
        self._error: BaseException | None = None
        self._submitted = self._completed = 0  # commits handed over; of them, those that completed (each one thread's)
        self._thread = threading.Thread(target=self._run, name="episode-committer", daemon=True)
        self._thread.start()

    @property
    def failed(self) -> bool:
        return self._error is not None

    @property
    def unfinished(self) -> int:
        """The commits handed over that have not completed: waiting, running, or failed (or not run after a failure)."""
        return self._submitted - self._completed

    def submit(self, commit: Callable[[], object]) -> None:
        self.raise_failed()
        self._submitted += 1
        self._q.put(commit)

    def drain(self) -> None:
        """Wait until every handed-over episode is committed; raise the first failure."""
        self._q.join()
        self.raise_failed()

    def raise_failed(self) -> None:
        if self._error is not None:
            raise self._error

    def close(self) -> None:
        """Finish the commits handed over, then stop the thread (the failure, if any, stays for `raise_failed`)."""
        self._q.put(None)
        self._thread.join()

    def _run(self) -> None:
        while True:
            commit = self._q.get()
            try:
                if commit is None:
                    return
                commit()
                self._completed += 1
            except BaseException as exc:  # noqa: BLE001 - raised on the recording's thread (`raise_failed`)
                if self._error is None:
                    self._error = exc
            finally:
                self._q.task_done()


def wait_videos(
    workers: Mapping[str, EncoderWorker], jobs: Mapping[str, EncodeJob], doing: str, root: Path
) -> dict[str, EncodedEpisode]:
    """Each camera's mp4 of an episode its encoders were told to finish (`jobs`); on a failure every one of them is
    deleted and the failure raised (a disk problem as `DiskError` while `doing`)."""
    encoded: dict[str, EncodedEpisode] = {}
    failure: BaseException | None = None
    for name, job in jobs.items():
        try:
            encoded[name] = workers[name].wait(job)
        except BaseException as exc:  # noqa: BLE001 - the others are still waited for, then this is raised
            failure = failure or exc
    if failure is None:
        return encoded
    for enc in encoded.values():
        enc.path.unlink(missing_ok=True)
    problem = disk_errno(failure)
    if problem is not None:
        raise disk_class(failure)(root, problem, doing) from failure
    raise failure
