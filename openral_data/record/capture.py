"""How a real-time recording (`record --hal`) kept up, over its session: the loop's overruns and missed ticks, and
per camera the frames recorded, the frames its encoder spilled to disk and encoded behind (formats/lerobot_v3/
video.py), the oldest sample a frame recorded (seconds since it arrived) and the longest a frame waited for its
encoder. Said in the run's summary (`record --hal --json`: `capture`) and kept in meta/openral.json (`capture`);
per episode the same numbers are in `openral.episode_info` (the `stats` report's `capture` table)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from openral_data.formats import atomic
from openral_data.formats.lerobot_v3 import LeRobotV3Writer, layout
from openral_data.formats.lerobot_v3.provenance import read_provenance
from openral_data.formats.lerobot_v3.video import CAPTURE, EncoderLag
from openral_data.record.hal_loop import EpisodeReport
from openral_data.types import Sink


@dataclass
class SessionCapture:
    """The kept episodes' cameras (`add`): per camera `frames`, `spilled`, `worst_frame_age_s`, `encoder_lag_s`;
    the loop's overruns and missed ticks are every attempt's (`to_json`)."""

    cameras: dict[str, dict[str, Any]] = field(default_factory=dict)

    def add(self, report: EpisodeReport, lag: Mapping[str, EncoderLag]) -> None:
        for name, age in report.max_age.items():
            zero = {"frames": 0, "spilled": 0, "worst_frame_age_s": 0.0, "encoder_lag_s": 0.0}
            cam = self.cameras.setdefault(name, zero)
            cam["frames"] += report.frames
            cam["worst_frame_age_s"] = max(cam["worst_frame_age_s"], round(age, 4))
            if name in lag:
                cam["spilled"] += lag[name].spilled
                cam["encoder_lag_s"] = max(cam["encoder_lag_s"], round(lag[name].max_lag, 4))

    def to_json(self, reports: Sequence[EpisodeReport]) -> dict[str, Any]:
        return {
            "overruns": sum(r.overruns for r in reports),
            "missed_ticks": sum(r.missed_ticks for r in reports),
            "cameras": {name: dict(cam) for name, cam in self.cameras.items()},
        }


def encoder_lag(sinks: Sequence[Sink], index: int) -> dict[str, EncoderLag]:
    """The LeRobot writer's per-camera spills and lag of episode `index`, once committed ({} without one)."""
    writers = [s for s in sinks if isinstance(s, LeRobotV3Writer)]
    return writers[0].encoder_lag(index) if writers else {}


def keep_capture(root: Path, capture: dict[str, Any]) -> None:
    """Write `capture` into `root`'s meta/openral.json (a LeRobot dataset this run wrote; nothing without one)."""
    written = read_provenance(root)
    if written is None:
        return
    atomic.write_bytes(root / layout.OPENRAL_PATH, replace(written, extra={**written.extra, CAPTURE: capture}).dumps())
