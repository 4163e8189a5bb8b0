"""What an episode looks like in rerun, shared by `view` (a recorded episode) and `record --view` (a live one).

The same entity paths and series styles give the same layout in the viewer: `task` (text), `cameras/<name>`,
`state/<dim>` and `action/<dim>` (one series per dimension, named after the contract), `outcome/reward` (line),
`outcome/success` and `outcome/done` (points), and `events` (a text log line when the episode ends), on the
timelines `frame_index` and `time`.
"""

from __future__ import annotations

from collections.abc import Sequence

import rerun as rr

from openral_data.formats.lerobot_v3.features import camera_name

APP_ID = "openral-data"
FRAME = "frame_index"
TIME = "time"
TASK = "task"
EVENTS = "events"
OUTCOMES = ("reward", "success", "done")  # `next.<name>` in a dataset


def camera_entity(camera: str) -> str:
    """`cameras/<name>`, for a dataset key (`features.camera_name`: `observation.images.<name>` or lerobot's
    `observation.image`) or a producer's camera name."""
    return f"cameras/{rr.escape_entity_path_part(camera_name(camera))}"


def series_entities(base: str, names: Sequence[str], dim: int) -> list[tuple[str, str]]:
    """(entity, series name) per dimension of `state` or `action`; a dimension without a name is `<base>_<i>`."""
    out = []
    for i in range(dim):
        name = names[i] if i < len(names) else f"{base}_{i}"
        out.append((f"{base}/{rr.escape_entity_path_part(name)}", name))
    return out


def outcome_entity(name: str) -> str:
    return f"outcome/{name}"


def log_series_styles(rec: rr.RecordingStream, series: Sequence[tuple[str, str]]) -> None:
    """Static: one named line per state/action dimension."""
    for entity, name in series:
        rec.log(entity, rr.SeriesLines(names=name), static=True)


def log_outcome_style(rec: rr.RecordingStream, name: str) -> None:
    """Static: reward is a line, success and done are points."""
    if name == "reward":
        rec.log(outcome_entity(name), rr.SeriesLines(names=name), static=True)
    else:
        rec.log(outcome_entity(name), rr.SeriesPoints(names=name, marker_sizes=4.0), static=True)


def log_episode_end(rec: rr.RecordingStream, episode: int, success: bool | None) -> None:
    """The `events` line at the current time: `episode N done: success|failure|unknown`."""
    label = "unknown" if success is None else ("success" if success else "failure")
    rec.log(EVENTS, rr.TextLog(f"episode {episode} done: {label}", level="INFO" if success else "WARN"))
