"""The dataset bridge: enforces the rSkill contract on every frame and assembles episodes for the sinks.

Pairing: row t holds the observation the policy saw at step t and the action it produced from it, plus what
followed that action (reward, done, success). The initial observation is a row; the observation after the
final step is not.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import numpy.typing as npt

from openral_data.errors import ContractViolation
from openral_data.types import (
    CommitsBehind,
    DatasetSchema,
    EpisodeRecord,
    EpisodeStart,
    Frame,
    FrameObserver,
    Observation,
    Sink,
)


def _describe(x: object) -> str:
    if isinstance(x, np.ndarray):
        return f"{x.dtype}{list(x.shape)}"
    return type(x).__name__


class DatasetBridge:
    """Validates frames against `schema` and fans them out to every sink, then to every observer."""

    def __init__(
        self,
        schema: DatasetSchema,
        sinks: Sequence[Sink],
        first_episode: int = 0,
        observers: Sequence[FrameObserver] = (),
    ) -> None:
        self.schema = schema
        self.sinks = list(sinks)
        self.observers = list(observers)
        self._camera_names = set(schema.cameras)
        self._episode = first_episode  # a resumed recording continues the numbering
        self._step = 0
        self._last_time = 0.0
        self._seed = 0
        self._open = False

    # -- validation ------------------------------------------------------------------------------------------
    def _where(self) -> str:
        return f"episode {self._episode} step {self._step}"

    def _vector(self, what: str, value: Any, dim: int) -> npt.NDArray[np.float32]:
        if not isinstance(value, np.ndarray):
            raise ContractViolation(f"{self._where()}: {what}: expected a float32 numpy array, got {_describe(value)}")
        if value.dtype != np.float32 or value.shape != (dim,):
            raise ContractViolation(f"{self._where()}: {what}: expected float32[{dim}], got {_describe(value)}")
        if not np.isfinite(value).all():
            bad = [int(i) for i in np.flatnonzero(~np.isfinite(value))[:5]]
            raise ContractViolation(f"{self._where()}: {what}: non-finite values at dims {bad}")
        return value.copy()

    def _images(self, images: Any) -> dict[str, npt.NDArray[Any]]:
        if not isinstance(images, dict):
            raise ContractViolation(f"{self._where()}: images: expected a dict of camera name -> array")
        names = set(images)
        if names != self._camera_names:
            missing, extra = sorted(self._camera_names - names), sorted(names - self._camera_names)
            raise ContractViolation(
                f"{self._where()}: images: cameras must be exactly {sorted(self._camera_names)}"
                + (f"; missing {missing}" if missing else "")
                + (f"; undeclared {extra}" if extra else "")
            )
        out: dict[str, npt.NDArray[Any]] = {}
        for name, img in images.items():
            shape = self.schema.cameras[name]
            # a depth camera: (H, W) uint16 millimetres or float32 metres; a segmentation mask: (H, W) uint16 ids
            dtype = (
                np.uint16
                if shape.segmentation
                else {None: np.uint8, "mm": np.uint16, "m": np.float32}[shape.depth_unit]
            )
            colour = shape.depth_unit is None and not shape.segmentation
            want = (shape.height, shape.width, 3) if colour else (shape.height, shape.width)
            kind = " (HWC)" if colour else " (segmentation)" if shape.segmentation else " (depth)"
            if not isinstance(img, np.ndarray) or img.dtype != dtype or img.shape != want:
                raise ContractViolation(
                    f"{self._where()}: images.{name}: expected {np.dtype(dtype).name}{list(want)}{kind}, "
                    f"got {_describe(img)}"
                )
            out[name] = np.array(img, order="C", copy=True)  # one copy, contiguous, whatever the input's layout
        return out

    def _transforms(self, value: Any) -> dict[str, npt.NDArray[np.float64]]:
        """The observation's mount-frame poses: frame name -> finite [x, y, z, qw, qx, qy, qz]."""
        if not isinstance(value, dict):
            raise ContractViolation(f"{self._where()}: transforms: expected a dict of frame name -> pose")
        out: dict[str, npt.NDArray[np.float64]] = {}
        for name, pose in value.items():
            arr = np.asarray(pose, dtype=np.float64)
            if not isinstance(name, str) or arr.shape != (7,) or not np.isfinite(arr).all():
                raise ContractViolation(f"{self._where()}: transforms.{name}: expected 7 finite numbers")
            out[name] = arr.copy()
        return out

    def _environment_state(self, value: Any) -> npt.NDArray[np.float32] | None:
        """The observation's environment state: a float32 vector of the schema's width, or absent when the schema
        names none (a frame without one, or with one the schema does not declare, breaks the contract)."""
        names = self.schema.environment_state_names
        if not names:
            if value is not None:
                raise ContractViolation(
                    f"{self._where()}: observation.environment_state: the dataset schema declares none"
                )
            return None
        return self._vector("observation.environment_state", value, len(names))

    def _timestamp(self, time: float | None) -> float:
        if time is None:
            return self._step / self.schema.fps
        t = float(time)
        if not np.isfinite(t) or t < 0 or t < self._last_time:
            raise ContractViolation(
                f"{self._where()}: time: expected a finite, non-decreasing time >= 0, got {time} "
                f"(previous {self._last_time})"
            )
        self._last_time = t
        return t

    def check_action(self, action: Any) -> None:
        """Validate a policy's action before it reaches the producer."""
        self._vector("action", action, self.schema.action_dim)

    # -- episode lifecycle -----------------------------------------------------------------------------------
    def begin_episode(self, seed: int, initial_state: dict[str, Any], index: int | None = None) -> None:
        """Open the next episode; `index` numbers it instead (only without sinks, whose numbering is their own:
        a replay watched by observers shows each replayed episode under its recorded number)."""
        if self._open:
            raise RuntimeError("begin_episode() while an episode is open")
        if index is not None:
            if self.sinks:
                raise RuntimeError("begin_episode(index=...) on a bridge with sinks")
            self._episode = index
        self._open = True
        self._step = 0
        self._last_time = 0.0
        self._seed = seed
        start = EpisodeStart(seed=seed, initial_state=initial_state)
        for sink in self.sinks:
            sink.begin_episode(start)
        for observer in self.observers:
            observer.begin_episode(self._episode, start)

    def _extras(self, extras: Mapping[str, float] | None) -> dict[str, float]:
        want = self.schema.frame_extras
        got = dict(extras or {})
        if set(got) != set(want):
            raise ContractViolation(f"{self._where()}: extras: expected keys {list(want)}, got {sorted(got)}")
        out = {k: float(got[k]) for k in want}
        bad = [k for k, v in out.items() if not np.isfinite(v)]
        if bad:
            raise ContractViolation(f"{self._where()}: extras: non-finite values for {bad}")
        return out

    def _columns(self, columns: Mapping[str, Any] | None) -> dict[str, npt.NDArray[Any]]:
        """The schema's `frame_columns` values: exactly its keys, a float32 vector of its width or a bool flag."""
        got = dict(columns or {})
        want = {c.key: c for c in self.schema.frame_columns}
        if set(got) != set(want):
            raise ContractViolation(f"{self._where()}: columns: expected keys {sorted(want)}, got {sorted(got)}")
        out: dict[str, npt.NDArray[Any]] = {}
        for key, col in want.items():
            if col.dtype == "bool":
                out[key] = np.array([bool(got[key])])
            else:
                out[key] = self._vector(key, got[key], col.dim)
        return out

    def add_step(
        self,
        observation: Observation,
        action: Any,
        *,
        reward: float,
        done: bool,
        success: bool,
        extras: Mapping[str, float] | None = None,
        columns: Mapping[str, Any] | None = None,
    ) -> None:
        """Record row t: `observation` (seen at step t), `action` (produced from it) and its outcome.

        `extras` carries the schema's `frame_extras` values for this row, `columns` its `frame_columns` values
        (none by default).
        """
        if not self._open:
            raise RuntimeError("add_step() outside an episode")
        if not isinstance(observation.task, str) or not observation.task:
            raise ContractViolation(f"{self._where()}: task: expected a non-empty string")
        frame = Frame(
            state=self._vector("observation.state", observation.state, self.schema.state_dim),
            action=self._vector("action", action, self.schema.action_dim),
            images=self._images(observation.images),
            task=observation.task,
            reward=float(reward),
            done=bool(done),
            success=bool(success),
            timestamp=self._timestamp(observation.time),
            extras=self._extras(extras),
            environment_state=self._environment_state(observation.environment_state),
            transforms=self._transforms(observation.transforms),
            columns=self._columns(columns),
        )
        if not np.isfinite(frame.reward):
            raise ContractViolation(f"{self._where()}: reward: non-finite value {reward}")
        for sink in self.sinks:
            sink.add_frame(frame)
        for observer in self.observers:
            observer.add_frame(frame)
        self._step += 1

    def end_episode(self, success: bool | None, info: dict[str, Any] | None = None) -> list[EpisodeRecord]:
        """Commit the episode. `info` (JSON-able) goes to sinks that store episode annotations."""
        if not self._open:
            raise RuntimeError("end_episode() outside an episode")
        if info is not None and self._step > 0:
            for sink in self.sinks:
                sink.annotate_episode(info)
        if self._step == 0:
            self.discard_episode()
            raise ContractViolation(f"episode {self._episode}: an episode needs at least one frame")
        known = None if success is None else bool(success)  # producers may hand numpy bools
        records = [sink.end_episode(known) for sink in self.sinks]
        # without sinks (a run only watched, e.g. `replay --mode closed-loop --save-video`) the episode is complete
        shown = records[0] if records else EpisodeRecord(self._episode, self._step, known, self._seed)
        self._open = False
        self._episode += 1
        for observer in self.observers:
            observer.end_episode(shown)
        return records

    def kept(self, ended: int) -> int:
        """How many of the `ended` episodes whose `end_episode` returned (the first ones) every sink holds committed:
        fewer when a sink commits behind the recording (`CommitsBehind`) and has not committed them all (yet, or
        because a commit failed); after `close()`, what the run kept."""
        return ended - max([0, *(s.uncommitted for s in self.sinks if isinstance(s, CommitsBehind))])

    def discard_episode(self) -> None:
        if not self._open:
            return
        self._open = False
        for sink in self.sinks:
            sink.discard_episode()
        for observer in self.observers:
            observer.end_episode(None)

    def close(self) -> None:
        self.discard_episode()
        errors = []
        closers: list[Sink | FrameObserver] = [*self.sinks, *self.observers]
        for sink in closers:
            try:
                sink.close()
            except Exception as exc:  # noqa: BLE001 - close every sink, then report
                errors.append(exc)
        if errors:
            raise errors[0]
