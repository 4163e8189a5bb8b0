"""Option choices shared by several commands."""

from __future__ import annotations

from enum import StrEnum


class CodecChoice(StrEnum):
    av1 = "av1"
    h264 = "h264"
