"""`openral-data doctor`: check a LeRobot v3 dataset (ours or lerobot's) against lerobot 0.6.1's format rules,
including those its loader gets silently wrong, and repair what can be repaired safely."""

from openral_data.doctor.check import check
from openral_data.doctor.check_missing import PARTIAL_DOWNLOAD
from openral_data.doctor.findings import Finding, Severity
from openral_data.doctor.repair import RepairResult, repair

__all__ = ["PARTIAL_DOWNLOAD", "Finding", "RepairResult", "Severity", "check", "repair"]
