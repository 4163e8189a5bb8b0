"""A source episode played again in its own recorded scene (no cameras): per frame, the end-effector pose, the
pose of every object and the action taken — what segmentation and re-targeting read. Replay restores the
recorded start and steps the recorded actions, so the trace is the episode's exact history."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from openral_data.errors import GenerateError
from openral_data.policies.mimicgen.poses import F64
from openral_data.replay.drive import drive, restore
from openral_data.replay.recorded import RecordedEpisode
from openral_data.types import Observation, SimRollout, StepResult


@dataclass
class Trace:
    episode: int
    ee_pos: list[F64] = field(default_factory=list)
    ee_quat: list[F64] = field(default_factory=list)
    objects: list[dict[str, tuple[F64, F64]]] = field(default_factory=list)  # name -> (pos, quat)
    movable: set[str] = field(default_factory=set)  # objects a gripper can hold (not visual, not fixed)
    actions: list[npt.NDArray[np.float32]] = field(default_factory=list)
    success: bool = False

    @property
    def length(self) -> int:
        return len(self.actions)


def trace(env: SimRollout, episode: RecordedEpisode, where: str) -> Trace:
    """`episode` replayed in `env` (built from the source's own scene) and traced frame by frame."""
    out = Trace(episode.index)
    obs, _ = restore(env, episode)
    _need_truth(obs, where)
    out.movable = {
        name
        for name, info in obs.privileged["objects"].items()
        if info.get("movable") and not info.get("visual") and not name.startswith("distractor_")
    }

    def seen(o: Observation, action: npt.NDArray[np.float32], result: StepResult, last: bool) -> None:
        p = o.privileged
        out.ee_pos.append(np.asarray(p["ee_pos"], dtype=np.float64))
        out.ee_quat.append(np.asarray(p["ee_quat"], dtype=np.float64))
        out.objects.append(
            {
                n: (np.asarray(i["pos"], dtype=np.float64), np.asarray(i["quat"], dtype=np.float64))
                for n, i in p["objects"].items()
            }
        )
        out.actions.append(np.asarray(action, dtype=np.float32))

    done = drive(env, obs, episode.length, lambda t, o: episode.actions[t], seen)
    out.success = done.success
    return out


def _need_truth(obs: Observation, where: str) -> None:
    missing = [k for k in ("ee_pos", "ee_quat", "objects") if k not in obs.privileged]
    if missing:
        raise GenerateError(
            f"{where}: the source scene reports no {', '.join(missing)}: generation needs a MuJoCo tabletop scene",
            code="generate.scene",
        )
