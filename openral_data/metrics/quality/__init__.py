"""Episode quality: idle time, frozen dimensions, jerk, gripper chatter, clipping, timestamp jitter and gaps, and
camera faults (black, saturated, frozen, blurred), one row per episode with a flag per fault and the findings
that raised each (`findings`: check, dimension or camera, frames, value against threshold) (docs/stats.md,
"Quality"): computed streaming (`compute`), cached beside the dataset or in the user's cache (`cache`), seen by
DuckDB as the `quality` and `quality_findings` views (`view`)."""

from __future__ import annotations

from typing import TYPE_CHECKING

from openral_data.lazy import lazy_names

# name -> the module that defines it: imported on first use, so `info` reads a cached table without importing
# the measures, PyAV or DuckDB
_API: dict[str, str] = {
    "DEFAULT": "openral_data.metrics.quality.thresholds",
    "DEFAULT_STRIDE": "openral_data.metrics.quality.thresholds",
    "FLAGS": "openral_data.metrics.quality.table",
    "Quality": "openral_data.metrics.quality.cached",
    "SCHEMA": "openral_data.metrics.quality.table",
    "Thresholds": "openral_data.metrics.quality.thresholds",
    "cached_quality": "openral_data.metrics.quality.cached",
    "counts_table": "openral_data.metrics.quality.view",
    "flag_counts": "openral_data.metrics.quality.view",
    "mentions_quality": "openral_data.metrics.quality.view",
    "parse_thresholds": "openral_data.metrics.quality.thresholds",
    "quality": "openral_data.metrics.quality.cached",
    "quality_of": "openral_data.metrics.quality.cached",
    "raised_text": "openral_data.metrics.quality.view",
    "register_quality": "openral_data.metrics.quality.view",
}

if TYPE_CHECKING:
    from openral_data.metrics.quality.cached import Quality, cached_quality, quality, quality_of
    from openral_data.metrics.quality.table import FLAGS, SCHEMA
    from openral_data.metrics.quality.thresholds import DEFAULT, DEFAULT_STRIDE, Thresholds, parse_thresholds
    from openral_data.metrics.quality.view import (
        counts_table,
        flag_counts,
        mentions_quality,
        raised_text,
        register_quality,
    )

__all__ = [
    "DEFAULT",
    "DEFAULT_STRIDE",
    "FLAGS",
    "SCHEMA",
    "Quality",
    "Thresholds",
    "cached_quality",
    "counts_table",
    "flag_counts",
    "mentions_quality",
    "parse_thresholds",
    "quality",
    "quality_of",
    "raised_text",
    "register_quality",
]


__getattr__ = lazy_names(__name__, _API)
