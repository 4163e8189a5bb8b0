"""Tests whose outcome hangs on wall-clock timing (signals after delays, slow workers, stale ticks, serial-bus
timeouts): under pytest-xdist (`-n N --dist loadgroup`) they run one after another on one worker, never beside
each other."""

from __future__ import annotations

import pytest

TIMED = pytest.mark.xdist_group("timed")
