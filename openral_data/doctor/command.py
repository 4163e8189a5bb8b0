"""`openral-data doctor DATASET [--repair] [--deep]`: the report text and the exit status (1 while errors
remain)."""

from __future__ import annotations

from pathlib import Path

from openral_data.doctor.check import check
from openral_data.doctor.findings import Finding
from openral_data.doctor.repair import repair


def run_doctor(root: Path, fix: bool, deep: bool = False) -> tuple[str, int]:
    lines: list[str] = []
    if fix:
        result = repair(root)
        lines += [f"refused  {r}" for r in result.refused]
        lines += [f"repaired {a}" for a in result.actions] or ([] if result.refused else ["nothing to repair"])
        if result.quarantine is not None:
            lines.append(f"kept     replaced files and removed rows under {result.quarantine}")
        findings = check(root, deep=True) if deep else result.remaining
    else:
        findings = check(root, deep=deep)
    lines.append(_summary(root, findings, after_repair=fix))
    lines += [f.line() for f in findings]
    return "\n".join(lines), 1 if any(f.severity == "error" for f in findings) else 0


def _summary(root: Path, findings: list[Finding], after_repair: bool) -> str:
    errors = sum(f.severity == "error" for f in findings)
    warnings = len(findings) - errors
    if not findings:
        return f"{root}: healthy"
    fixable = sum(f.repairable for f in findings)
    hint = "" if after_repair or not fixable else f"; {fixable} repairable with --repair"
    left = "still " if after_repair else ""
    return f"{root}: {left}{errors} error(s), {warnings} warning(s){hint}"
