"""The log lines of an episode's commit: how long it took and how long its frames waited on the encoders."""

from __future__ import annotations

import logging
from collections.abc import Mapping

from openral_data.formats.lerobot_v3.video import EncoderWorker


def log_commit(
    log: logging.Logger, index: int, flush_ms: float, commit_ms: float, workers: Mapping[str, EncoderWorker]
) -> None:
    """INFO: episode `index`'s commit time and how long its frames waited on full encoder queues (all cameras);
    DEBUG: the waits per camera. `log` is the writer's logger (its name is in the lines)."""
    waited = {name: round(w.waited * 1000, 1) for name, w in workers.items()}
    waits = sum(w.waits for w in workers.values())
    log.info(
        "episode %d committed in %.0f ms (encoders flushed in %.0f ms; frames waited %.0f ms on full encoder "
        "queues, %d times)",
        index,
        flush_ms + commit_ms,
        flush_ms,
        sum(waited.values()),
        waits,
        extra={
            "episode": index,
            "flush_ms": round(flush_ms, 1),
            "commit_ms": round(commit_ms, 1),
            "encoder_wait_ms": round(sum(waited.values()), 1),
            "encoder_waits": waits,
        },
    )
    for name, w in workers.items():
        log.debug(
            "episode %d camera %s: waited %.1f ms on a full encoder queue, %d times",
            index,
            name,
            waited[name],
            w.waits,
            extra={"episode": index, "camera": name, "encoder_wait_ms": waited[name], "encoder_waits": w.waits},
        )
