"""A LeRobot v3 dataset opened for editing: its schema, tasks and episodes, read lazily.

Editing rebuilds a dataset through our own writer, so a source must have columns our writer can reproduce:
its `info.json` features must be what `build_features` makes from the schema read back here (state/action
dtype, shape and dimension names, video cameras under the source's own keys, outcomes), except that a camera's
`info` block is kept as the source wrote it, state/action names may be lerobot's `{"motors": [...]}` form
(compared by `dim_names`) and `next.done` may be absent; any other numeric feature of one axis
(`observation.environment_state`) and any `dtype: image` camera is carried as its stored column (`carried`; an
image's `{bytes, path}` cells unchanged, its per-episode statistics taken from meta/episodes, as a video
camera's are). A camera is named as `features.camera_keys` names it (lerobot/pusht's `observation.image` is
`image`) and written under its own key. The output keeps the source's features verbatim. The dataset need not
be ours: our `openral.*` episode columns (`features.EPISODE_EXTRA_COLUMNS`: success, seed, initial state, episode
info) are carried when present and never required. Without them an episode's seed is unknown (`None`), its
initial state empty, its info absent, and its success read by the rule `metrics` uses: `openral.success`, else
whether any frame has `next.success`, else unknown.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
import pyarrow as pa
import pyarrow.compute as pc

from openral_data.edit.recode import clip_frames, image_frames
from openral_data.edit.renames import check_renames, renamed
from openral_data.errors import DatasetError, EpisodeSelectionError, NotFound
from openral_data.formats import atomic
from openral_data.formats.jsonfile import parse_field, parse_json
from openral_data.formats.lerobot_v3 import layout
from openral_data.formats.lerobot_v3.clip import episode_clip
from openral_data.formats.lerobot_v3.config import WriterConfig
from openral_data.formats.lerobot_v3.encoder import VideoSettings
from openral_data.formats.lerobot_v3.features import (
    ACTION,
    STATE,
    build_features,
    camera_keys,
    camera_name,
    data_schema,
    dim_names,
)
from openral_data.formats.lerobot_v3.lock import check_settled
from openral_data.formats.lerobot_v3.masks import decode_mask, is_mask, mask_stats
from openral_data.formats.lerobot_v3.missing import missing_files
from openral_data.formats.lerobot_v3.provenance import Origin, read_provenance
from openral_data.formats.lerobot_v3.reader import dataset_tasks, read_episodes, read_info
from openral_data.formats.lerobot_v3.stats import STAT_KEYS, ImageStatsAccumulator, Stats
from openral_data.formats.lerobot_v3.variants import camera_layout, feature_info, is_depth, without_fps
from openral_data.formats.parquetfile import read_table
from openral_data.types import CameraShape, DatasetSchema


@dataclass(frozen=True)
class EpisodeData:
    """One source episode, ready to be written again under a new index."""

    source: Path
    index: int  # in the source
    length: int
    states: npt.NDArray[np.float32]
    actions: npt.NDArray[np.float32]
    rewards: list[float]
    dones: list[bool]
    successes: list[bool]
    tasks: list[str]  # per frame
    seed: int | None  # None: the source did not record it
    success: bool | None
    initial_state: dict[str, Any]
    info: Any  # its `openral.episode_info` (JSON: who drove it, a HAL's report...); None: the source has none
    videos: dict[str, bytes]  # camera name -> a complete mp4 of exactly `length` frames starting at pts 0
    image_stats: dict[str, Stats]  # camera name -> the episode's statistics from the source metadata
    columns: dict[str, pa.Array]  # carried features (`SourceDataset.carried`), as stored
    column_stats: dict[str, Stats]  # carried image features -> the episode's statistics from the source metadata


class SourceDataset:
    def __init__(
        self, root: Path, renames: Mapping[str, str] | None = None, flags: tuple[str, str] = ("--rename",) * 2
    ) -> None:
        """`renames`: features presented under new keys (`edit.renames`; OLD -> NEW, given by the options
        `flags`), read from their stored ones."""
        self.root = root
        if not root.is_dir():
            raise NotFound(f"{root}: no such dataset folder")
        check_settled(root, "edit")
        self.info = read_info(root)
        self.fps = int(self.info["fps"])
        check_renames(self.info["features"], renames or {}, str(root), flags)
        self.features: dict[str, dict[str, Any]] = renamed(self.info["features"], renames or {})
        self.stored = {new: old for old, new in (renames or {}).items()}  # a presented key -> its key on disk
        self.episodes = read_episodes(root)
        info_total = int(self.info.get("total_episodes", 0))
        self.total = min(info_total, self.episodes.num_rows)  # the loader exposes no more than info's total
        self.task_names = dataset_tasks(root, self.info)
        self.origin = self._origin()
        # camera name -> key of every video camera (`features.camera_keys`: lerobot/pusht's `observation.image`
        # is `image`); a `dtype: image` camera is a carried column
        self.camera_key = {n: k for n, k in camera_keys(self.features).items() if self.features[k]["dtype"] == "video"}
        self.video = self._video_settings()
        self.schema = self._schema()
        self._check_reproducible()
        self._types = data_schema(self.features)
        self._rows = self.episodes.to_pylist()
        order = [int(r["episode_index"]) for r in self._rows]
        if order[: self.total] != list(range(self.total)):
            raise DatasetError(
                f"{root}: meta/episodes: rows are not episodes 0..{self.total - 1} in order", code="dataset.invalid"
            )
        self._data_cache: tuple[Path, pa.Table] | None = None
        # the files a partial download left out: an edit asks only for those it copies (`need`)
        stored = [self.key_on_disk(k) for k in self.camera_key.values()]
        self.missing = missing_files(root, self.info, self._rows[: self.total], stored)

    # -- what the dataset is ---------------------------------------------------------------------------------
    def _origin(self) -> Origin:
        """Where the source's frames came from (its `meta/openral.json`), carried into what an edit writes; empty
        for a dataset without one."""
        provenance = read_provenance(self.root)
        return provenance.origin if provenance is not None and provenance.origin is not None else Origin()

    def camera_names(self) -> list[str]:
        return list(self.camera_key)

    def key_on_disk(self, key: str) -> str:
        """The stored key of a feature presented as `key` (itself unless renamed)."""
        return self.stored.get(key, key)

    def _video_settings(self) -> VideoSettings:
        infos = [feature_info(f) for f in self.features.values() if f.get("dtype") == "video"]
        if not infos:
            return VideoSettings()
        i = infos[0]
        codec = i.get("video.codec")
        if codec not in ("av1", "h264", "hevc"):
            raise DatasetError(
                f"{self.root}/meta/info.json: video.codec: {codec!r} is not av1, h264 or hevc",
                code="dataset.unsupported",
            )
        crf = i.get("video.crf", 30)
        pix_fmt = i.get("video.pix_fmt")
        return VideoSettings(
            codec=codec,
            crf=crf if isinstance(crf, int | float) and not isinstance(crf, bool) else 30,
            g=int(i.get("video.g", 2)),
            preset=i.get("video.preset"),
            pix_fmt=pix_fmt if isinstance(pix_fmt, str) else "yuv420p",
        )

    def _schema(self) -> DatasetSchema:
        where = f"{self.root}/meta/info.json: features"
        try:
            state, action = self.features[STATE], self.features[ACTION]
        except KeyError as exc:
            raise DatasetError(f"{where}.{exc.args[0]}: missing", code="dataset.invalid") from None
        cameras = {name: _camera_shape(self.features[key]) for name, key in self.camera_key.items()}
        return DatasetSchema(
            fps=self.fps,
            state_names=tuple(dim_names(state, STATE)),
            action_names=tuple(dim_names(action, ACTION)),
            cameras=cameras,
            robot_type=self.info.get("robot_type"),  # a string or null (`info.check_info`)
            metadata=self.origin.to_json(),
            has_reward="next.reward" in self.features,
            has_success="next.success" in self.features,
        )

    def _check_reproducible(self) -> None:
        rebuilt = build_features(self.schema, self.video, keys=self.camera_key)
        if "next.done" not in self.features:
            del rebuilt["next.done"]
        where = f"{self.root}/meta/info.json: features"
        self.carried = [k for k, f in self.features.items() if k not in rebuilt and _carriable(f)]
        for key in self.features.keys() - set(self.carried) | rebuilt.keys():
            ours, theirs = dict(rebuilt.get(key) or {}), without_fps(dict(self.features.get(key) or {}))
            if ours.get("dtype") == "video" and theirs.get("dtype") == "video":
                # the encoder settings (`info`, a legacy `video_info`) are the source's, packets are copied, not
                # encoded; `channel` or `channels` names the same axis
                ours, theirs = camera_layout(ours), camera_layout(theirs)
            if key in (STATE, ACTION):  # names as a list or lerobot's `{"motors": [...]}`: kept verbatim
                ours["names"], theirs["names"] = dim_names(ours, key), dim_names(theirs, key)
            if key not in rebuilt or key not in self.features or ours != theirs:
                raise DatasetError(
                    f"{where}.{key}: not a feature layout openral-data writes; cannot edit this dataset",
                    code="dataset.unsupported",
                )

    def image_hist(self) -> dict[str, ImageStatsAccumulator] | None:
        """The writer's dataset-level camera histograms (`.openral/image_hist.json`), if it left them."""
        path = self.root / layout.IMAGE_HIST_PATH
        try:
            saved = parse_json(atomic.read_control(path))  # a control file: no symlink, no FIFO, bounded
        except (FileNotFoundError, ValueError):
            return None
        if not isinstance(saved, dict):
            return None
        out: dict[str, ImageStatsAccumulator] = {}
        stored_name = {n: camera_name(self.key_on_disk(k)) for n, k in self.camera_key.items()}
        for name in self.camera_names():
            if stored_name[name] not in saved:
                return None
            out[name] = ImageStatsAccumulator.from_json(saved[stored_name[name]])
        return out

    def writer_config(self) -> WriterConfig:
        i = self.info
        return WriterConfig(
            video=self.video,
            data_files_size_in_mb=int(i.get("data_files_size_in_mb", 100)),
            video_files_size_in_mb=int(i.get("video_files_size_in_mb", 200)),
            chunks_size=int(i.get("chunks_size", layout.DEFAULT_CHUNKS_SIZE)),
            durable=False,
        )

    # -- episodes --------------------------------------------------------------------------------------------
    def seed(self, index: int) -> int:
        """The episode's recording seed; refused in one line when the dataset did not record it."""
        value = self._rows[index].get("openral.seed")
        if value is None:
            raise DatasetError(
                f"{self.root}: meta/episodes: openral.seed: "
                + (
                    "no such column"
                    if "openral.seed" not in self.episodes.column_names
                    else f"episode {index} has none"
                )
                + "; its recording seed is unknown (use --order input)",
                code="dataset.unsupported",
            )
        return int(value)

    def need(self, episodes: Iterable[int], cameras: Iterable[str], what: str) -> None:
        """Refuse in one line, before anything is written, when a file that copying `episodes` with the video
        `cameras` (names) needs is absent (a partial download: `missing.MissingFiles.need`)."""
        keys = [self.key_on_disk(self.camera_key[n]) for n in cameras if n in self.camera_key]
        self.missing.need(episodes, keys, what, drop=True)

    def episode(self, index: int, cameras: Iterable[str] | None = None) -> EpisodeData:
        """Episode `index` with the videos of `cameras` (names; default every video camera): a camera an edit
        drops is never read, so its mp4 need not be there."""
        if not 0 <= index < self.total:
            raise EpisodeSelectionError(
                f"{self.root}: episode {index} is outside 0..{self.total - 1}", code="episodes.range"
            )
        row = self._rows[index]
        n = int(row["length"])
        data = self._episode_rows(row)
        if data.num_rows != n:
            raise DatasetError(
                f"{self.root}: episode {index}: {data.num_rows} data rows, meta/episodes says {n}",
                code="dataset.invalid",
            )
        task_idx = data.column("task_index").to_numpy()
        try:
            tasks = [self.task_names[int(i)] for i in task_idx]
        except IndexError:
            raise DatasetError(
                f"{self.root}: episode {index}: task_index outside meta/tasks.parquet", code="dataset.invalid"
            ) from None
        videos: dict[str, bytes] = {}
        image_stats: dict[str, Stats] = {}
        wanted = self.camera_names() if cameras is None else [c for c in self.camera_names() if c in set(cameras)]
        for name in wanted:
            videos[name] = self._clip(index, row, name, n)
            image_stats[name] = self._picture_stats(row, self.camera_key[name], videos[name])
        states, actions = self._vector(data, STATE, index), self._vector(data, ACTION, index)
        initial, info = row.get("openral.initial_state"), row.get("openral.episode_info")
        successes = _list(data, "next.success", False)
        seed = row.get("openral.seed")
        return EpisodeData(
            source=self.root,
            index=index,
            length=n,
            states=states,
            actions=actions,
            rewards=_list(data, "next.reward", 0.0),
            dones=_list(data, "next.done", False),
            successes=successes,
            tasks=tasks,
            seed=None if seed is None else int(seed),
            success=self._success(row, successes),
            initial_state=parse_field(initial, f"{self.root}: episode {index}: openral.initial_state")
            if initial
            else {},
            info=None if info is None else parse_field(info, f"{self.root}: episode {index}: openral.episode_info"),
            videos=videos,
            image_stats=image_stats,
            columns={
                key: data.column(self.key_on_disk(key)).combine_chunks().cast(self._types.field(key).type)
                for key in self.carried
            },
            column_stats={
                key: self._picture_stats(row, key, data.column(self.key_on_disk(key)).combine_chunks())
                for key in self.carried
                if self.features[key]["dtype"] == "image"
            },
        )

    def _vector(self, data: pa.Table, key: str, index: int) -> npt.NDArray[np.float32]:
        """The episode's rows of `key` (state or action), refused in one line unless they have the width
        info.json declares (the writer would otherwise fail casting them, deep inside the copy)."""
        matrix = _matrix(data.column(key))
        want = self.features[key]["shape"][0]
        if matrix.shape[1] != want:
            raise DatasetError(
                f"{self.root / layout.INFO_PATH}: features: {key}: shape [{want}] but the data of episode "
                f"{index} holds {matrix.shape[1]} values a frame",
                code="dataset.invalid",
            )
        return matrix

    def _stats(self, row: dict[str, Any], key: str) -> Stats:
        """A feature's statistics for one episode as meta/episodes has them."""
        stored = self.key_on_disk(key)
        try:
            return {
                s: np.asarray(row[f"stats/{stored}/{s}"], dtype=np.int64 if s == "count" else np.float64)
                for s in STAT_KEYS
            }
        except (KeyError, TypeError, ValueError):
            raise DatasetError(
                f"{self.root}: meta/episodes: stats/{stored}: missing or not numbers (episode {row['episode_index']})",
                code="dataset.invalid",
            ) from None

    def _picture_stats(self, row: dict[str, Any], key: str, pixels: bytes | pa.Array) -> Stats:
        """A camera's statistics for one episode as meta/episodes has them; computed from its pixels (`pixels`:
        the episode's mp4, or its `dtype: image` cells) as `stats recompute` does when the source has none
        (statistics are optional to lerobot's loader: older or foreign datasets may lack them, or lack only the
        quantiles, as lerobot's v2.1 -> v3.0 converter leaves them)."""
        if all(row.get(f"stats/{self.key_on_disk(key)}/{s}") is not None for s in STAT_KEYS):
            return self._stats(row, key)
        where = f"{self.root}: {key}: episode {row['episode_index']}"
        self.refuse_depth(key, "computing a depth camera's missing statistics")
        if isinstance(pixels, bytes):
            frames: Iterator[npt.NDArray[np.uint8]] = clip_frames(pixels, where)
        elif is_mask(self.features[key]):
            return mask_stats([decode_mask(c, f"{where}: frame {i}") for i, c in enumerate(pixels.to_pylist())])
        else:
            frames = image_frames(pixels, where)
        acc = ImageStatsAccumulator()
        for frame in frames:
            acc.add(frame)
        return acc.stats()

    def refuse_depth(self, key: str, what: str) -> None:
        """One line refusing `what` for a depth camera (`variants.is_depth`): its statistics are in its depth
        unit from the dequantized frames, which editing does not compute yet (copying them is fine)."""
        if is_depth(self.features[key]):
            raise DatasetError(
                f"{self.root / layout.INFO_PATH}: features.{key}: {what} is not supported yet",
                code="dataset.unsupported",
            )

    def _success(self, row: dict[str, Any], successes: list[bool]) -> bool | None:
        if "openral.success" in self.episodes.column_names:
            value = row["openral.success"]
            return None if value is None else bool(value)
        return any(successes) if self.schema.has_success else None

    def _episode_rows(self, row: dict[str, Any]) -> pa.Table:
        path = layout.data_path(self.root, layout.FilePos(int(row["data/chunk_index"]), int(row["data/file_index"])))
        if self._data_cache is None or self._data_cache[0] != path:
            self._data_cache = (path, read_table(path))
        table = self._data_cache[1]
        rows = table.filter(pc.equal(table.column("episode_index"), int(row["episode_index"])))
        return rows.sort_by("frame_index")

    def _clip(self, index: int, row: dict[str, Any], name: str, n: int) -> bytes:
        key = self.key_on_disk(self.camera_key[name])
        pos = layout.FilePos(int(row[f"videos/{key}/chunk_index"]), int(row[f"videos/{key}/file_index"]))
        path = layout.video_path(self.root, key, pos)
        if not path.is_file():
            raise DatasetError(
                f"{path}: video file named by meta/episodes (episode {index}) is missing", code="dataset.incomplete"
            )
        start = float(row[f"videos/{key}/from_timestamp"])
        clip = episode_clip(path, start, start + n / self.fps, self.fps)
        if clip.data is None:
            raise DatasetError(
                f"{path}: episode {index} does not start on a keyframe; cannot cut it without re-encoding",
                code="dataset.unsupported",
            )
        if clip.frames != n:
            raise DatasetError(
                f"{path}: episode {index} has {clip.frames} video frames, meta/episodes says {n}",
                code="dataset.invalid",
            )
        return clip.data


def _camera_shape(feature: dict[str, Any]) -> CameraShape:
    """A video camera's shape; a depth camera (`variants.is_depth`) with its `depth_unit` (lerobot's default mm)."""
    shape = camera_layout(feature)["shape"]  # height, width, channels (also of a channel-first feature)
    height, width = int(shape[0]), int(shape[1])
    if not is_depth(feature):
        return CameraShape(height, width)
    return CameraShape(height, width, "m" if feature_info(feature).get("depth_unit") == "m" else "mm")


def _carriable(feature: dict[str, Any]) -> bool:
    """A numeric per-frame feature (float32, int64 or bool, one axis) or an image (height, width, 3; a segmentation
    mask's (height, width, 1)) that editing copies as it is."""
    shape = feature.get("shape")
    if feature.get("dtype") == "image":
        return (
            isinstance(shape, list)
            and len(shape) == 3
            and all(isinstance(d, int) and d >= 1 for d in shape)
            and shape[2] == (1 if is_mask(feature) else 3)
        )
    return (
        feature.get("dtype") in ("float32", "int64", "bool")
        and isinstance(shape, list)
        and len(shape) == 1
        and isinstance(shape[0], int)
        and shape[0] >= 1
    )


def _matrix(col: pa.ChunkedArray) -> npt.NDArray[np.float32]:
    arr = col.combine_chunks()
    if pa.types.is_fixed_size_list(arr.type) or pa.types.is_list(arr.type):
        flat = np.asarray(arr.flatten().to_numpy(zero_copy_only=False), dtype=np.float32)
        return flat.reshape(len(arr), -1)
    return np.asarray(arr.to_numpy(zero_copy_only=False), dtype=np.float32).reshape(-1, 1)


def _list[T](table: pa.Table, key: str, default: T) -> list[T]:
    if key not in table.column_names:
        return [default] * table.num_rows
    values: list[T] = table.column(key).to_pylist()
    return values
