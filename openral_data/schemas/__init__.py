"""Pydantic schemas: the single source of truth for robot, rSkill and scene files."""

from openral_data.schemas.base import StrictModel, load_model
from openral_data.schemas.robot import RobotManifest
from openral_data.schemas.rskill import Contract, RSkillManifest
from openral_data.schemas.scene import (
    AnyScene,
    BenchmarkScene,
    DeployScene,
    SceneCamera,
    SimScene,
    load_recordable_scene,
    load_scene,
)

__all__ = [
    "AnyScene",
    "BenchmarkScene",
    "Contract",
    "DeployScene",
    "RSkillManifest",
    "RobotManifest",
    "SceneCamera",
    "SimScene",
    "StrictModel",
    "load_model",
    "load_recordable_scene",
    "load_scene",
]
