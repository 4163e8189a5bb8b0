"""`--record OUT`: write the replayed (or closed-loop) rollouts as a new dataset through the normal bridge and
sinks, e.g. with other cameras or resolutions (`--cameras FILE`), the "states to observations" use case.

`--cameras FILE` is YAML: `cameras:` a list in the scene schema (name, width, height, mount, pos, lookat, fovy)
and optionally `render:` (shadows, reflections, robot_meshes). It replaces the recorded cameras; physics does
not depend on cameras, so the replay is the same.

OUT is written in a hidden staging folder beside it (`formats.staging`) and renamed into place when the replay
ends normally; a failed or killed replay leaves nothing under OUT.

The same bridge feeds a closed-loop replay's `--save-video` / `--view` observers (openral_data/runtime/observers.py)
the frames `record` would show them; without `--record` it has no sinks and only they watch the run.
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np
import numpy.typing as npt
from pydantic import Field

from openral_data.errors import CompatibilityError
from openral_data.formats.codec import Codec
from openral_data.formats.lerobot_v3 import VideoSettings, WriterConfig
from openral_data.formats.lerobot_v3.provenance import ReplayOrigin
from openral_data.formats.mcap import ImageFormat
from openral_data.formats.staging import Staging
from openral_data.replay.drive import StepHook
from openral_data.replay.rebuild import Rebuilt, SceneView
from openral_data.replay.summary import Rerecorded
from openral_data.runtime.bridge import DatasetBridge
from openral_data.runtime.outdir import check_out
from openral_data.runtime.schema import scene_schema
from openral_data.runtime.sinks import OutputFormat, make_sinks
from openral_data.schemas.base import StrictModel, load_model
from openral_data.schemas.scene import RenderConfig, SceneCamera
from openral_data.types import DatasetSchema, EpisodeRecord, FrameObserver, Observation, Sink, StepResult


class CameraFile(StrictModel):
    cameras: list[SceneCamera] = Field(min_length=1)
    render: RenderConfig | None = None


def load_view(path: Path) -> SceneView:
    view = load_model(CameraFile, path)
    return SceneView(cameras=tuple(view.cameras), render=view.render)


Observe = Callable[[DatasetSchema], Sequence[FrameObserver]]  # the run's schema -> the observers watching it


class Rerecorder:
    """One bridge for the whole replay; `begin()` gives the hook feeding it the steps of the episode in flight.
    `out` None: nothing is written, the bridge only shows the frames to what `observe` returns."""

    def __init__(
        self,
        out: Path | None,
        built: Rebuilt,
        dataset_root: Path,
        mode: str,
        codec: Codec = "av1",
        formats: tuple[OutputFormat, ...] = ("lerobot",),
        image_format: ImageFormat = "jpeg",
        observe: Observe | None = None,
    ) -> None:
        video = VideoSettings(codec=codec)
        spec = built.env.spec
        if out is not None:
            check_out(out)
            for name, shape in spec.cameras.items():
                problem = video.size_problem(shape.height, shape.width)
                if problem:
                    raise CompatibilityError(f"--cameras: {name}: {problem}")
        schema = scene_schema(
            spec,
            built.scene,
            built.source,
            built.robot,
            built.rskill,
            built.rskill_source,
            ReplayOrigin(str(dataset_root.resolve()), mode),
        )
        self.out = out
        self.env = built.env
        observers = list(observe(schema)) if observe is not None else []
        sinks: list[Sink] = []
        self._staged: Staging | None = None
        try:
            if out is not None:
                self._staged = Staging(out, "openral-data replay --record")  # OUT appears complete or not at all
                staging = self._staged.open()
                sinks = make_sinks(staging, schema, formats, WriterConfig(video=video), image_format)
        except BaseException:
            if self._staged is not None:
                self._staged.discard()
            with contextlib.suppress(Exception):  # closes the observers; the error is the one raised
                DatasetBridge(schema, [], observers=observers).close()
            raise
        self.bridge = DatasetBridge(schema, sinks, observers=observers)
        self.records: list[EpisodeRecord] = []
        self._success = False
        self._seed = 0
        self._index: int | None = None
        self._opened = False

    def begin(self, seed: int | None, index: int) -> StepHook:
        """The hook for recorded episode `index`. The replayer restores the start itself, so the first step opens
        the episode in the bridge (with the initial state the scene then reports). Without OUT the observers show
        it as episode `index`; with OUT it is the next episode of OUT."""
        self._seed = 0 if seed is None else seed
        self._index = index if self.out is None else None
        self._opened = False
        return self._step

    def _step(self, obs: Observation, action: npt.NDArray[np.float32], result: StepResult, done: bool) -> None:
        if not self._opened:
            self.bridge.begin_episode(self._seed, self.env.initial_state(), self._index)
            self._opened = True
        self.bridge.add_step(obs, action, reward=result.reward, done=done, success=bool(result.success))
        self._success = bool(result.success) if result.terminated else False

    def end(self) -> None:
        if self._opened:
            self.records.extend(self.bridge.end_episode(self._success)[:1])
            self._opened = False

    def close(self, ok: bool) -> Rerecorded | None:
        """Close the sinks and observers; a replay that ended normally publishes OUT, one that failed leaves
        nothing there. What was re-recorded (None without OUT)."""
        try:
            if not ok:
                self.bridge.discard_episode()
            self.bridge.close()
            if ok and self._staged is not None:
                self._staged.publish("--record")
        finally:
            if self._staged is not None:
                self._staged.discard()  # (nothing left to remove once published)
        if self.out is None:
            return None
        return Rerecorded(out=str(self.out), episodes=len(self.records), frames=sum(r.length for r in self.records))
