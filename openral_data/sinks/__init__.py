"""Sinks: where validated frames go (LeRobot v3 now; MCAP later)."""
