"""`videos reencode` and `videos encode-images`: a dataset's cameras decoded and encoded again, written as a new
dataset (or in place) through the editing path (`ops.write_edit`: atomic, lock-aware, episodes re-indexed as
they are).

- `reencode`: the chosen video cameras (all by default) are decoded and encoded again with `codec` (lerobot
  0.6.1's encoder settings, `VideoSettings`), resized to `size` if given; their feature `shape` and `info`
  block follow. The other cameras' packets are copied (the edit path's clip), not decoded.
- `encode_images`: the chosen `dtype: image` features (all by default) become `dtype: video` cameras with the
  feature and `info` block lerobot's `LeRobotDataset.create(use_videos=True)` writes; their parquet column is
  dropped and their frames are encoded into `videos/KEY/chunk-*/file-*.mp4`.

Camera statistics of a camera encoded here are recomputed, per episode and for the dataset, from the frames
handed to the encoder (the decoded source frames, resized; or the decoded images), as the writer does while
recording: the old ones describe other pixels (a resize; or a codec change, which is lossy). The dataset-level
ones are exact (histograms) when the source kept its writer histograms for the untouched cameras, else merged
from the episodes' statistics (`assemble`). Everything else (rows, tasks, success, other cameras) is the source's.
"""

from __future__ import annotations

import re
from collections.abc import Iterator, Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

from openral_data.edit.ops import EditResult, Rewrite, check_edit_output, summed_histograms, write_edit
from openral_data.edit.recode import CameraEncoders, Pixels, clip_frames, image_frames
from openral_data.edit.source import EpisodeData, SourceDataset
from openral_data.errors import DatasetError, UsageError
from openral_data.formats.lerobot_v3.config import WriterConfig
from openral_data.formats.lerobot_v3.encoder import VideoSettings
from openral_data.formats.lerobot_v3.features import camera_keys
from openral_data.formats.lerobot_v3.masks import is_mask
from openral_data.formats.lerobot_v3.reader import read_info
from openral_data.formats.lerobot_v3.stats import ImageStatsAccumulator
from openral_data.text import did_you_mean
from openral_data.types import CameraShape

_SIZE = re.compile(r"([0-9]{1,5})x([0-9]{1,5})")
VIDEO_NAMES = ["height", "width", "channels"]


def parse_size(text: str) -> CameraShape:
    """`--size WIDTHxHEIGHT` (e.g. 640x480)."""
    m = _SIZE.fullmatch(text.strip())
    if m is None:
        raise UsageError(f"--size: {text!r} is not WIDTHxHEIGHT, e.g. 640x480")
    return CameraShape(height=int(m.group(2)), width=int(m.group(1)))


def settings_for(codec: str, video: VideoSettings | None = None) -> VideoSettings:
    """`--vcodec` applied to the other encoder settings, resolved and checked (`VideoSettings.given`)."""
    return VideoSettings.given(codec, video=video)


def choose_cameras(
    features: dict[str, dict[str, Any]], cameras: Sequence[str], dtype: str, dataset: Path
) -> dict[str, str]:
    """The `dtype` cameras named by `--camera` (a feature key, or a camera name as `features.camera_keys` names it:
    `wrist` for `observation.images.wrist`, `image` for lerobot/pusht's `observation.image`), or all of them when
    none is named: camera name -> feature key."""
    names = camera_keys(features)
    every = {name: key for name, key in names.items() if features[key].get("dtype") == dtype}
    if not cameras:
        if not every:
            raise UsageError(f"{dataset}: has no {dtype} cameras (features of dtype {dtype})")
        return every
    name_of = {key: name for name, key in names.items()}
    chosen: dict[str, str] = {}
    for given in cameras:
        key = given if given in features else names.get(given)
        if key is None:
            known = ", ".join(every.values()) or "none"
            hint = did_you_mean(given, [*every, *every.values()])  # a camera's name or its feature key
            raise UsageError(f"--camera: {given!r} is not a feature of {dataset}{hint} ({dtype} cameras: {known})")
        found = features[key].get("dtype")
        if found != dtype:
            raise UsageError(f"--camera: {key} is a {found} feature, not a {dtype} camera")
        chosen[name_of[key]] = key
    return chosen


def _video_feature(old: dict[str, Any], shape: CameraShape, settings: VideoSettings, fps: int) -> dict[str, Any]:
    info = old.get("info") if old.get("dtype") == "video" else None
    return {
        "dtype": "video",
        "shape": [shape.height, shape.width, 3],
        "names": old.get("names") or VIDEO_NAMES,
        # keys the source added to a video's info (e.g. intrinsics) stay; the encoding's own keys are new
        "info": {**(info if isinstance(info, dict) else {}), **settings.feature_info(shape.height, shape.width, fps)},
    }


def _histograms(src: SourceDataset, encoded: Sequence[str]) -> dict[str, ImageStatsAccumulator] | None:
    """The output's dataset-level histograms, when exact ones are possible: the source's for the cameras copied,
    fresh ones (filled as episodes are encoded) for the cameras encoded here."""
    kept = [name for name in src.camera_names() if name not in encoded]
    base = summed_histograms([src]) if kept else {}
    if base is None:
        return None
    hist = {name: base[name] for name in kept}
    hist.update({name: ImageStatsAccumulator() for name in encoded})
    return hist


class _Recoder:
    """The per-episode step of both operations: encode the chosen cameras, keep the rest of the episode."""

    def __init__(
        self,
        src: SourceDataset,
        shapes: dict[str, CameraShape],
        settings: VideoSettings,
        hist: dict[str, ImageStatsAccumulator] | None,
        size: CameraShape | None = None,
    ) -> None:
        self.src, self.shapes, self.hist, self.size = src, shapes, hist, size
        self.keys = camera_keys(src.features)
        self.encoders = CameraEncoders(shapes, settings, src.fps)

    def episode(self, ep: EpisodeData) -> EpisodeData:
        where = f"{self.src.root}: episode {ep.index}"
        columns = dict(ep.columns)
        frames = {name: self._frames(ep, columns, name, where) for name in self.shapes}
        encoded = self.encoders.encode(frames, ep.length, where)
        if self.hist is not None:
            for name, enc in encoded.items():
                self.hist[name].merge(enc.stats)
        return replace(
            ep,
            videos={**ep.videos, **{name: enc.data for name, enc in encoded.items()}},
            image_stats={**ep.image_stats, **{name: enc.stats.stats() for name, enc in encoded.items()}},
            columns=columns,
        )

    def _frames(self, ep: EpisodeData, columns: dict[str, Any], name: str, where: str) -> Iterator[Pixels]:
        key = self.keys[name]
        if key in columns:  # an image feature becoming a video: its column goes
            return image_frames(columns.pop(key), f"{where}: {key}")
        return clip_frames(ep.videos[name], f"{where}: {key}", self.size)


def reencode(
    dataset: Path,
    codec: str,
    size: str | None = None,
    cameras: Sequence[str] = (),
    out: Path | None = None,
    in_place: bool = False,
    video: VideoSettings | None = None,
) -> EditResult:
    """Decode and encode again the chosen video cameras of `dataset` (all by default) with `codec` (and `video`'s
    other encoder settings), resized to `size` (WIDTHxHEIGHT) if given; the other cameras' packets are copied."""
    check_edit_output(out, in_place)  # before any decoding
    settings = settings_for(codec, video)
    target = None if size is None else parse_size(size)
    problem = None if target is None else settings.size_problem(target.height, target.width)
    if problem:
        raise UsageError(f"--size: {problem}")
    src = SourceDataset(dataset)
    names = list(choose_cameras(src.features, cameras, "video", dataset))
    for name in names:
        src.refuse_depth(src.camera_key[name], "videos reencode")
    shapes = {name: target or src.schema.cameras[name] for name in names}
    every = set(names) == set(src.camera_names())
    config = replace(src.writer_config(), video=settings if every else src.video)
    resized = None if target is None else f"{target.width}x{target.height}"
    return _recode(src, shapes, settings, config, "reencode", {"size": resized}, out, in_place, target)


def encode_images(
    dataset: Path,
    cameras: Sequence[str] = (),
    codec: str = "av1",
    out: Path | None = None,
    in_place: bool = False,
    video: VideoSettings | None = None,
) -> EditResult:
    """Turn the chosen `dtype: image` features of `dataset` (all by default) into video cameras encoded with
    `codec` (and `video`'s other encoder settings); every other column and camera is the source's."""
    check_edit_output(out, in_place)  # before any decoding
    settings = settings_for(codec, video)
    # (a missing folder is SourceDataset's to report)
    features = read_info(dataset)["features"] if dataset.is_dir() else {}
    keys = choose_cameras(features, cameras, "image", dataset) if dataset.is_dir() else {}
    # a segmentation mask stays lossless PNGs: never chosen by default, refused by name
    for name, key in list(keys.items()):
        if is_mask(features[key]):
            if cameras:
                raise UsageError(f"--camera: {key} is a segmentation mask (kept lossless, not encoded as a video)")
            del keys[name]
    if dataset.is_dir() and not keys:
        raise UsageError(f"{dataset}: has no image cameras besides segmentation masks")
    src = SourceDataset(dataset)  # refuses what it cannot edit (a busy or interrupted dataset, a foreign layout)
    shapes: dict[str, CameraShape] = {}
    for name, key in keys.items():
        shape = src.features[key].get("shape")
        if not (isinstance(shape, list) and len(shape) == 3 and shape[2] == 3 and all(_positive(v) for v in shape)):
            raise DatasetError(
                f"{dataset}/meta/info.json: features.{key}.shape: {shape!r} is not [height, width, 3]",
                code="dataset.invalid",
            )
        shapes[name] = CameraShape(height=shape[0], width=shape[1])
    config = replace(src.writer_config(), video=src.video if src.camera_names() else settings)
    return _recode(src, shapes, settings, config, "encode-images", {}, out, in_place)


def _positive(value: object) -> bool:
    return isinstance(value, int) and not isinstance(value, bool) and value >= 1


def _recode(
    src: SourceDataset,
    shapes: dict[str, CameraShape],
    settings: VideoSettings,
    config: WriterConfig,
    op: str,
    details: dict[str, Any],
    out: Path | None,
    in_place: bool,
    size: CameraShape | None = None,
) -> EditResult:
    """Write `src` with the cameras `shapes` names encoded with `settings` (at those sizes), through `write_edit`."""
    for name, shape in shapes.items():
        problem = settings.size_problem(shape.height, shape.width)
        if problem:
            raise UsageError(f"--vcodec: camera {name}: {problem}")
    features = dict(src.features)
    keys = camera_keys(features)  # the output keeps each camera's key, so its name too
    for name, shape in shapes.items():
        features[keys[name]] = _video_feature(features[keys[name]], shape, settings, src.fps)
    schema = replace(src.schema, cameras={**src.schema.cameras, **shapes})
    hist = _histograms(src, list(shapes))
    details = {"codec": settings.codec, **details, "cameras": [keys[name] for name in shapes]}
    recoder = _Recoder(src, shapes, settings, hist, size)
    try:
        rewrite = Rewrite(recoder.episode, schema, features, config, image_hist=hist, details=details)
        keep = [(src, e) for e in range(src.total)]
        return write_edit(keep, src.root, out, in_place, op, rewrite)
    finally:
        recoder.encoders.close()
