"""The log lines of a recording run (INFO, structured fields in `extra=`; the CLI decides where they go)."""

from __future__ import annotations

import logging
from pathlib import Path

from openral_data.types import EpisodeRecord

log = logging.getLogger(__name__)


def outcome(success: bool | None) -> str:
    return "unknown" if success is None else "success" if success else "failure"


def log_episode(rec: EpisodeRecord, seconds: float) -> None:
    """One finished episode (`record`: committed; `record --hal`: handed to the committer): its index, seed,
    length, outcome and wall time."""
    log.info(
        "episode %d (seed %d): %d frames, %s, %.2f s",
        rec.index,
        rec.seed,
        rec.length,
        outcome(rec.success),
        seconds,
        extra={
            "episode": rec.index,
            "seed": rec.seed,
            "length": rec.length,
            "outcome": outcome(rec.success),
            "seconds": round(seconds, 3),
        },
    )


def log_totals(out: Path, episodes: int, frames: int, seconds: float) -> None:
    """The run's totals: episodes saved, frames, wall time of the episode loop."""
    log.info(
        "saved %d episode(s), %d frames in %.1f s to %s",
        episodes,
        frames,
        seconds,
        out,
        extra={"saved": episodes, "frames": frames, "seconds": round(seconds, 3), "out": str(out)},
    )
