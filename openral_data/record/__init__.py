"""The `record` command: its options and summary, the output folder's lifecycle (fresh / resume / lock), the
concurrent start, the sim and HAL episode loops, and parallel recording (`--workers`). What it shares with the
other tools (bridge, registries, compatibility, sinks, observers, executors) is `openral_data.runtime`."""

__all__ = ["hal", "hal_loop", "options", "output", "parallel", "runlog", "session", "sim", "start"]
