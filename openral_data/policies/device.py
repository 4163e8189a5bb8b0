"""The torch device a neural policy runs on: `cpu`, `cuda`, `cuda:N`, `mps` or `auto` (cuda if torch sees one,
else mps, else cpu). A device this machine does not have is refused in one line naming where it was asked for
(`--device`, or an rSkill's `policy_extras.device`). Policies without a network ignore the device."""

from __future__ import annotations

import re
from typing import Any

from openral_data.errors import ConfigError, OpenralError, UsageError, install_hint
from openral_data.schemas.rskill import RSkillManifest

CHOICES = "cpu, cuda, cuda:N, mps, auto"


def resolve_device(requested: str, where: str = "--device") -> str:
    """The device `requested` names, checked against what torch sees here. `where` names the option or field
    (an rSkill field's errors are ConfigErrors, the command line's UsageErrors)."""
    spec = requested.strip().lower()
    torch = _torch(where)
    if spec == "auto":
        if torch.cuda.is_available():
            return "cuda"
        return "mps" if _mps(torch) else "cpu"
    if spec == "cpu":
        return "cpu"
    if spec == "mps":
        if not _mps(torch):
            raise _error(where, f"{requested}: torch sees no MPS (Apple GPU) device here; use cpu or auto")
        return "mps"
    match = re.fullmatch(r"cuda(?::(\d+))?", spec)
    if match is None:
        raise _error(where, f"{requested!r} is not a device ({CHOICES})")
    count = int(torch.cuda.device_count()) if torch.cuda.is_available() else 0
    if count == 0:
        raise _error(where, f"{requested}: torch sees no CUDA device here; use cpu or auto")
    index = int(match.group(1) or 0)
    if index >= count:
        raise _error(where, f"{requested}: torch sees {count} CUDA device(s) (cuda:0..cuda:{count - 1})")
    return spec


def _torch(where: str) -> Any:
    try:
        import torch
    except ImportError:
        raise _error(where, f"needs torch, which comes with the 'lerobot' extra: {install_hint('lerobot')}") from None
    return torch


def _mps(torch: Any) -> bool:
    backend = getattr(torch.backends, "mps", None)
    return bool(backend is not None and backend.is_available())


def _error(where: str, what: str) -> OpenralError:
    return UsageError(f"{where}: {what}") if where.startswith("--") else ConfigError(f"{where}: {what}")


def with_device(rskill: RSkillManifest, device: str | None) -> RSkillManifest:
    """`rskill` with `policy_extras.device` set to `device` (`--device` wins over the rSkill's); unchanged for None."""
    if device is None:
        return rskill
    return rskill.model_copy(update={"policy_extras": {**rskill.policy_extras, "device": device}})
