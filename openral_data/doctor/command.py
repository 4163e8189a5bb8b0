"""`openral-data doctor DATASET [--repair] [--deep]`: the report (as text or as `--json`'s fields) and the exit
status (1 while errors remain)."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from openral_data.doctor.check import check
from openral_data.doctor.check_v2 import legacy_version
from openral_data.doctor.findings import Finding
from openral_data.doctor.repair import repair
from openral_data.errors import DatasetError


@dataclass(frozen=True)
class DoctorReport:
    root: Path
    findings: list[Finding]  # what the final check finds (after --repair: what is left)
    repair: bool = False  # --repair was asked for
    repaired: list[str] = field(default_factory=list)  # what --repair did, one line each
    refused: list[str] = field(default_factory=list)  # why --repair did nothing (more), one line each
    quarantine: Path | None = None  # where --repair kept the files and rows it replaced

    @property
    def exit_code(self) -> int:
        """1 while errors remain, or when `--repair` refused (it did not finish: the dataset is not repaired)."""
        return 1 if self.refused or any(f.severity == "error" for f in self.findings) else 0

    def text(self) -> str:
        lines: list[str] = []
        if self.repair:
            lines += [f"refused  {r}" for r in self.refused]
            lines += [f"repaired {a}" for a in self.repaired] or ([] if self.refused else ["nothing to repair"])
            if self.quarantine is not None:
                lines.append(f"kept     replaced files and removed rows under {self.quarantine}")
        lines.append(_summary(self.root, self.findings, after_repair=self.repair))
        lines += [f.line() for f in self.findings]
        return "\n".join(lines)

    def to_json(self) -> dict[str, object]:
        """The fields of `doctor --json`, in docs/scripting.md's order."""
        errors = sum(f.severity == "error" for f in self.findings)
        return {
            "path": str(self.root),
            "healthy": not self.findings,
            "errors": errors,
            "warnings": len(self.findings) - errors,
            "findings": [f.to_json() for f in self.findings],
            "repair": self.repair,
            "repaired": list(self.repaired),
            "refused": list(self.refused),
            "quarantine": None if self.quarantine is None else str(self.quarantine),
            "exit_code": self.exit_code,
        }


def doctor_report(root: Path, fix: bool, deep: bool = False) -> DoctorReport:
    """Check `root` (after repairing it, with `fix`); `deep` also decodes every frame."""
    if not fix:
        return DoctorReport(root, check(root, deep=deep))
    legacy = legacy_version(root)
    if legacy:
        raise DatasetError(
            f"{root}: doctor --repair: LeRobot {legacy} is not repaired in place; run "
            f"`openral-data upgrade {root} NEW` and repair the v3 dataset",
            code="dataset.unsupported",
        )
    result = repair(root)
    findings = check(root, deep=True) if deep else result.remaining
    return DoctorReport(root, findings, True, list(result.actions), list(result.refused), result.quarantine)


def run_doctor(root: Path, fix: bool, deep: bool = False) -> tuple[str, int]:
    """The report's text and the exit status."""
    report = doctor_report(root, fix, deep)
    return report.text(), report.exit_code


def _summary(root: Path, findings: list[Finding], after_repair: bool) -> str:
    errors = sum(f.severity == "error" for f in findings)
    warnings = len(findings) - errors
    if not findings:
        return f"{root}: healthy"
    fixable = sum(f.repairable for f in findings)
    hint = "" if after_repair or not fixable else f"; {fixable} repairable with --repair"
    left = "still " if after_repair else ""
    return f"{root}: {left}{errors} error(s), {warnings} warning(s){hint}"
