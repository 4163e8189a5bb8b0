"""Producers: simulated scenes (`sim/`) and hardware HALs (`hal/`) that emit observations."""

from openral_data.producers.base import CameraShape, Observation, ProducerSpec, SimRollout, StepResult

__all__ = ["CameraShape", "Observation", "ProducerSpec", "SimRollout", "StepResult"]
