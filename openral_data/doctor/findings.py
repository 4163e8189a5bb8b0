"""What `doctor` reports: one finding per problem, with a severity, the file it is about and whether
`doctor --repair` can fix it safely."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from openral_data.text import printable

Severity = Literal["error", "warning"]


@dataclass(frozen=True)
class Finding:
    severity: Severity
    code: str  # stable identifier, e.g. "tasks.order"; tests and scripts match on it
    where: str  # file relative to the dataset root, or "dataset"
    message: str
    repairable: bool = False

    def line(self) -> str:
        """One line: a message quoting dataset text (a feature key) shows its line breaks and controls escaped."""
        tag = " [repairable]" if self.repairable else ""
        return printable(f"{self.severity:<7} {self.where}: {self.message}{tag}")

    def to_json(self) -> dict[str, object]:
        """One element of `doctor --json`'s `findings`."""
        return {
            "code": self.code,
            "severity": self.severity,
            "where": self.where,
            "message": self.message,
            "repairable": self.repairable,
        }


def error(code: str, where: str, message: str, repairable: bool = False) -> Finding:
    return Finding("error", code, where, message, repairable)


def warning(code: str, where: str, message: str, repairable: bool = False) -> Finding:
    return Finding("warning", code, where, message, repairable)


# `doctor`'s scan of what a dataset means (`check_scan`, over `metrics.signals`): warnings, stable codes
SCAN_QUATERNION_FLIP = "scan.quaternion_flip"  # a quaternion's sign flips between two frames
SCAN_ANGLE_WRAP = "scan.angle_wrap"  # an angle-like column jumps by ~2π between two frames
SCAN_TIMESTAMP_RATE = "scan.timestamp_rate"  # timestamps off the declared fps
SCAN_VIDEO_LENGTH = "scan.video_length"  # an episode's video holds more frames (or lasts longer) than its rows
