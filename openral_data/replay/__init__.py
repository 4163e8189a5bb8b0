"""Replay: recorded actions back through the rebuilt scene, and policies against recorded episodes.

Entry point: `replay(ReplayOptions(...)) -> ReplaySummary` (the `openral-data replay` command wraps it).
"""

from openral_data.replay.command import MODES, ReplayOptions, ReplaySummary, replay

__all__ = ["MODES", "ReplayOptions", "ReplaySummary", "replay"]
