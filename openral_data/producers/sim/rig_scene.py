"""The `render` / `initial_state` / `close` part of a SimRollout that is the same in every MuJoCo scene drawn
through a CameraRig (tabletop, robosuite, MetaWorld)."""

from __future__ import annotations

from typing import Any

import mujoco
import numpy as np
import numpy.typing as npt

from openral_data.producers.sim.mujoco.render import CameraRig


class RigScene:
    """Subclasses set `rig` (their cameras), `data` (the MuJoCo state drawn) and `initial` (this episode's
    start, as `initial_state()` hands it out); one wrapping a simulator environment sets `env`, closed last."""

    rig: CameraRig
    data: mujoco.MjData
    initial: dict[str, Any]
    env: Any = None

    def render(self) -> dict[str, npt.NDArray[np.uint8]]:
        return self.rig.render(self.data)

    def initial_state(self) -> dict[str, Any]:
        return dict(self.initial)

    def close(self) -> None:
        self.rig.close()
        if self.env is not None:
            self.env.close()
