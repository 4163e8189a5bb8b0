"""openral-data: robot rollouts -> datasets people train on (LeRobot v3, ROS 2 MCAP).

The Python API (docs/python-api.md); the `openral-data` command line wraps the same functions:

- recording: `record(RecordOptions(...)) -> RecordSummary`
- replay: `replay(ReplayOptions(...)) -> ReplaySummary`
- conversion: `convert(source, dst, mapping=None, ...) -> ConvertSummary | ExportSummary` (bags, HDF5, Zarr,
  RLDS -> LeRobot v3; LeRobot -> MCAP), `convert_bags(...) -> ConvertSummary`, `export_mcap(...) -> ExportSummary`,
  `export(dataset, out, to) -> ExportSummary` (LeRobot -> RLDS, robomimic HDF5 or MCAP; `export_rlds`,
  `export_robomimic`),
  `upgrade(old, new) -> UpgradeResult` (LeRobot v2.0/v2.1 -> v3.0 with lerobot's converter)
- checking: `check(root) -> list[Finding]`, `repair(root) -> RepairResult`
- reading: `summarize(root) -> DatasetSummary`, `stats_query(paths, sql) -> Table` (DuckDB over the stats views),
  `quality(root, stride, Thresholds(...)) -> Quality` (episode quality measures and flags, cached)
- extending: `SCENES` and `POLICIES` (`@SCENES.register("id")` over a factory; plug-ins also use entry points),
  `ROBOTS` (every robot manifest on the search path; docs/plugins.md)
- the schemas (`RobotManifest`, `RSkillManifest`, `SimScene`, `BenchmarkScene`, `load_scene`), the shared types
  (`Observation`, `Frame`, `DatasetSchema`, `EpisodeRecord`, `SimRollout`, `Sink`, ...) and errors (`OpenralError`).

Names load on first use, so `import openral_data` stays cheap and importing one submodule never pulls in the
simulators behind another.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from openral_data.version import __version__

# public name -> the module that defines it
_API: dict[str, str] = {
    "record": "openral_data.record.sim",
    "SCENES": "openral_data.runtime.registry",
    "POLICIES": "openral_data.runtime.registry",
    "ROBOTS": "openral_data.runtime.registry",
    "RecordOptions": "openral_data.record.options",
    "RecordSummary": "openral_data.record.options",
    "replay": "openral_data.replay",
    "ReplayOptions": "openral_data.replay",
    "ReplaySummary": "openral_data.replay",
    "convert": "openral_data.convert",
    "Parallel": "openral_data.convert",
    "convert_bags": "openral_data.convert",
    "ConvertSummary": "openral_data.convert",
    "export": "openral_data.convert",
    "export_mcap": "openral_data.convert",
    "export_rlds": "openral_data.convert",
    "export_robomimic": "openral_data.convert",
    "ExportSummary": "openral_data.convert",
    "upgrade": "openral_data.upgrade",
    "UpgradeResult": "openral_data.upgrade",
    "check": "openral_data.doctor",
    "repair": "openral_data.doctor",
    "Finding": "openral_data.doctor",
    "RepairResult": "openral_data.doctor",
    "summarize": "openral_data.formats.dataset",  # any version: v3, or v2.x read in place
    "DatasetSummary": "openral_data.formats.lerobot_v3",
    "stats_query": "openral_data.metrics.command",
    "quality": "openral_data.metrics.quality",
    "Quality": "openral_data.metrics.quality",
    "Thresholds": "openral_data.metrics.quality",
    "Table": "openral_data.metrics.report",
    "RobotManifest": "openral_data.schemas",
    "RSkillManifest": "openral_data.schemas",
    "SimScene": "openral_data.schemas",
    "BenchmarkScene": "openral_data.schemas",
    "load_scene": "openral_data.schemas",
    "CameraShape": "openral_data.types",
    "DatasetSchema": "openral_data.types",
    "EpisodeRecord": "openral_data.types",
    "Frame": "openral_data.types",
    "Observation": "openral_data.types",
    "ProducerSpec": "openral_data.types",
    "SimRollout": "openral_data.types",
    "Sink": "openral_data.types",
    "StepResult": "openral_data.types",
    "OpenralError": "openral_data.errors",
    "ConfigError": "openral_data.errors",
    "ContractViolation": "openral_data.errors",
    "CompatibilityError": "openral_data.errors",
}

__all__ = [
    "POLICIES",
    "ROBOTS",
    "SCENES",
    "BenchmarkScene",
    "CameraShape",
    "CompatibilityError",
    "ConfigError",
    "ContractViolation",
    "ConvertSummary",
    "DatasetSchema",
    "DatasetSummary",
    "EpisodeRecord",
    "ExportSummary",
    "Finding",
    "Frame",
    "Observation",
    "OpenralError",
    "Parallel",
    "ProducerSpec",
    "Quality",
    "RSkillManifest",
    "RecordOptions",
    "RecordSummary",
    "RepairResult",
    "ReplayOptions",
    "ReplaySummary",
    "RobotManifest",
    "SimRollout",
    "SimScene",
    "Sink",
    "StepResult",
    "Table",
    "Thresholds",
    "UpgradeResult",
    "__version__",
    "check",
    "convert",
    "convert_bags",
    "export",
    "export_mcap",
    "export_rlds",
    "export_robomimic",
    "load_scene",
    "quality",
    "record",
    "repair",
    "replay",
    "stats_query",
    "summarize",
    "upgrade",
]

if TYPE_CHECKING:
    from openral_data.convert import (
        ConvertSummary,
        ExportSummary,
        Parallel,
        convert,
        convert_bags,
        export,
        export_mcap,
        export_rlds,
        export_robomimic,
    )
    from openral_data.doctor import Finding, RepairResult, check, repair
    from openral_data.errors import CompatibilityError, ConfigError, ContractViolation, OpenralError
    from openral_data.formats.dataset import summarize
    from openral_data.formats.lerobot_v3 import DatasetSummary
    from openral_data.metrics.command import stats_query
    from openral_data.metrics.quality import Quality, Thresholds, quality
    from openral_data.metrics.report import Table
    from openral_data.record.options import RecordOptions, RecordSummary
    from openral_data.record.sim import record
    from openral_data.replay import ReplayOptions, ReplaySummary, replay
    from openral_data.runtime.registry import POLICIES, ROBOTS, SCENES
    from openral_data.schemas import BenchmarkScene, RobotManifest, RSkillManifest, SimScene, load_scene
    from openral_data.types import (
        CameraShape,
        DatasetSchema,
        EpisodeRecord,
        Frame,
        Observation,
        ProducerSpec,
        SimRollout,
        Sink,
        StepResult,
    )
    from openral_data.upgrade import UpgradeResult, upgrade


def __getattr__(name: str) -> Any:
    module = _API.get(name)
    if module is None:
        raise AttributeError(f"module 'openral_data' has no attribute {name!r}")
    imported = importlib.import_module(module)
    if name == "convert":  # the package, callable (importing it already set it here, a module attribute)
        return imported
    value = getattr(imported, name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(__all__)
