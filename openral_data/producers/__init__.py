"""Producers: simulated scenes (`sim/`) and hardware HAL drivers (`hal/`) that emit observations."""
