"""What a dataset recorded, as replay needs it: provenance (scene, rSkill, robot), per-episode seed, initial
state and success, the state/action rows of an episode, and (for policy mode) its decoded frames.

Works on any LeRobot v3 dataset for what the frame table holds; the scene and initial states exist only in
datasets openral-data recorded (`meta/openral.json`, `openral.*` episode columns).
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
import pyarrow as pa
import pyarrow.compute as pc

from openral_data.episodes import parse_episodes
from openral_data.errors import ConfigError, DatasetError, ReplayError
from openral_data.formats.jsonfile import parse_json
from openral_data.formats.lerobot_v3 import layout
from openral_data.formats.lerobot_v3.features import camera_keys
from openral_data.formats.lerobot_v3.frames import episode_frames as decode_episode_frames
from openral_data.formats.lerobot_v3.missing import missing_files
from openral_data.formats.lerobot_v3.provenance import Origin, Recorded, read_provenance
from openral_data.formats.lerobot_v3.reader import dataset_tasks, read_episodes, read_info
from openral_data.formats.lerobot_v3.success import episode_successes
from openral_data.formats.parquetfile import read_table
from openral_data.schemas.base import validate
from openral_data.schemas.rskill import RSkillManifest
from openral_data.schemas.scene import BenchmarkScene, SimScene
from openral_data.types import Frame

F32 = npt.NDArray[np.float32]
STATE, ACTION = "observation.state", "action"


@dataclass(frozen=True)
class RecordedEpisode:
    """One episode's numeric rows (frame t: the state seen and the action taken) and how it started/ended."""

    index: int
    seed: int | None
    initial_state: dict[str, Any] | None
    success: bool | None  # None: the dataset does not know
    states: F32  # (length, state_dim)
    actions: F32  # (length, action_dim)
    task: str
    overruled: bool = False  # the recorded success is an operator's verdict the scene's criterion contradicted

    @property
    def length(self) -> int:
        return int(self.actions.shape[0])


class RecordedDataset:
    """A LeRobot v3 dataset opened for replay (nothing is loaded until asked for)."""

    def __init__(self, root: Path) -> None:
        self.root = root
        self.info = read_info(root)
        features = self.info.get("features", {})
        for key in (STATE, ACTION):
            if key not in features:
                raise ReplayError(f"{root / layout.INFO_PATH}: features: no {key!r}; nothing to replay")
        self.fps = int(self.info["fps"])
        self.cameras = list(camera_keys(features))  # names; `observation.image` (lerobot/pusht) is `image`
        table = read_episodes(root)
        keep = [c for c in table.column_names if not c.startswith("stats/")]
        self._episodes = table.select(keep)
        self._rows = sorted(self._episodes.to_pylist(), key=lambda r: int(r["episode_index"]))
        self._tasks = dataset_tasks(root, self.info)
        self._data_cache: tuple[Path, pa.Table] | None = None

    def __len__(self) -> int:
        return len(self._rows)

    def select(self, spec: str | None) -> list[int]:
        """`--episodes 0,3,5-7` -> episode indices (all when None)."""
        return parse_episodes(spec, len(self._rows))

    # -- provenance --------------------------------------------------------------------------------------------
    @cached_property
    def provenance(self) -> Origin | None:
        """Where the frames came from (`schema_metadata`); None without `meta/openral.json` (or with one whose
        `schema_metadata` is not an object)."""
        openral = read_provenance(self.root)
        return openral.origin if openral is not None else None

    def _origin(self, key: str) -> Origin:
        """The recorded origin, refused when it lacks `key` (`scene`, `rskill`, `robot`) altogether."""
        meta = self.provenance
        if meta is None:
            raise ReplayError(
                f"{self.root}: no {layout.OPENRAL_PATH}: the dataset was not recorded by openral-data, so its scene "
                "cannot be rebuilt (use --mode policy, which needs no simulator)"
            )
        if not meta.present(key):
            where = self.root / layout.OPENRAL_PATH
            raise ReplayError(f"{where}: schema_metadata.{key}: missing (not a recording of a scene)")
        return meta

    def _recorded(self, key: str) -> Recorded | None:
        meta = self._origin(key)
        return meta.scene if key == "scene" else meta.rskill

    def _recorded_config(self, key: str) -> tuple[dict[str, Any], str]:
        """The `config` mapping recorded under `schema_metadata.<key>`, and where it is (for error messages)."""
        entry = self._recorded(key)
        config = entry.config if entry is not None else None
        source = f"{self.root / layout.OPENRAL_PATH}: schema_metadata.{key}.config"
        if config is None:
            raise ReplayError(f"{source}: missing")
        return config, source

    def hal_recording(self) -> bool:
        """Whether `record --hal` recorded it from a robot (its twin or the real one), not from a scene."""
        meta = self.provenance
        if meta is None or meta.present("scene"):
            return False
        return meta.hal is not None and meta.hal.scene is None

    def scene(self) -> SimScene:
        """The scene exactly as it was recorded (the YAML file may have changed since)."""
        config, source = self._recorded_config("scene")
        model: type[SimScene] = BenchmarkScene if config.get("tier") == "benchmark" else SimScene
        try:
            return validate(model, config, source)
        except ConfigError as exc:
            raise ConfigError(f"{exc} (recorded by an incompatible openral-data version?)") from None

    def scene_source(self) -> str:
        entry = self._recorded("scene")
        path = entry.path if entry is not None else None
        return f"{path} (as recorded in {self.root})" if path else str(self.root / layout.OPENRAL_PATH)

    def rskill(self) -> RSkillManifest:
        config, source = self._recorded_config("rskill")
        return validate(RSkillManifest, config, source)

    def robot(self) -> str:
        robot = self._origin("robot").robot
        if robot is None:
            raise ReplayError(f"{self.root / layout.OPENRAL_PATH}: schema_metadata.robot: missing")
        return robot

    # -- episodes ------------------------------------------------------------------------------------------------
    def need_files(self, episodes: list[int], pixels: bool, what: str) -> None:
        """Refuse in one line, before anything runs, when the data of `episodes` (and with `pixels` their videos)
        is absent: a partial download (`missing.MissingFiles.need`)."""
        features = self.info.get("features", {})
        videos = [k for k in camera_keys(features).values() if features[k].get("dtype") == "video"] if pixels else []
        missing_files(self.root, self.info, [self._rows[e] for e in episodes], videos).need(episodes, videos, what)

    def row(self, e: int) -> dict[str, Any]:
        row: dict[str, Any] = self._rows[e]
        return row

    def episode(self, e: int) -> RecordedEpisode:
        row = self._rows[e]
        n = int(row["length"])
        pos = layout.FilePos(row["data/chunk_index"], row["data/file_index"])
        path = layout.template_path(self.root, self.info, "data_path", pos)
        table = self._data(path)
        table = table.filter(pc.equal(table.column("episode_index"), e)).sort_by("frame_index")
        if table.num_rows != n:
            raise DatasetError(
                f"{path}: episode {e} has {table.num_rows} rows, meta/episodes says {n}", code="dataset.invalid"
            )
        states = _matrix(table.column(STATE), n)
        actions = _matrix(table.column(ACTION), n)
        raw_state = row.get("openral.initial_state")
        try:
            initial = parse_json(raw_state) if raw_state else None
        except ValueError as exc:
            raise ReplayError(f"{self.root}: meta/episodes: openral.initial_state of episode {e}: {exc}") from None
        task_index = int(table.column("task_index")[0].as_py()) if n else 0
        return RecordedEpisode(
            index=e,
            seed=None if row.get("openral.seed") is None else int(row["openral.seed"]),
            initial_state=initial if isinstance(initial, dict) and initial else None,
            success=self.success(e),
            states=states,
            actions=actions,
            task=self._tasks[task_index] if task_index < len(self._tasks) else "",
            overruled=operator_overruled(row.get("openral.episode_info")),
        )

    def _data(self, path: Path) -> pa.Table:
        """The numeric columns of one data file; the last file read is kept (episodes share files, in order)."""
        if self._data_cache is None or self._data_cache[0] != path:
            columns = ["episode_index", "frame_index", "task_index", STATE, ACTION]
            self._data_cache = (path, read_table(path, columns=columns))
        return self._data_cache[1]

    @cached_property
    def _successes(self) -> dict[int, bool | None]:
        return episode_successes(self.root, self._episodes)

    def success(self, e: int) -> bool | None:
        """By the one rule (`formats.lerobot_v3.success`): openral.success, else any next.success, else None."""
        return self._successes.get(e)

    def frames(self, e: int) -> Iterator[Frame]:
        """Episode `e` frame by frame with its camera images decoded (PyAV), as the policy saw them."""
        return decode_episode_frames(self.root, self.info, self._rows[e], self._tasks, self.cameras)


def _matrix(column: Any, n: int) -> F32:
    flat = np.asarray(column.combine_chunks().flatten().to_numpy(zero_copy_only=False), dtype=np.float32)
    return flat.reshape(n, -1) if n else flat.reshape(0, 0)


def operator_overruled(raw: object) -> bool:
    """Whether an episode record (`openral.episode_info`, JSON) says its success is the operator's verdict
    (`operator_verdict`) while the scene's criterion (`scene_success`) said otherwise (record/hal_loop.py)."""
    try:
        info = parse_json(raw) if isinstance(raw, str) and raw else None
    except ValueError:
        return False  # not ours to judge: the outcome is only explained less
    if not isinstance(info, dict):
        return False
    said, scene = info.get("operator_verdict"), info.get("scene_success")
    return said in ("success", "failure") and isinstance(scene, bool) and (said == "success") != scene
