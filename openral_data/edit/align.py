"""`episodes merge` of datasets that differ: keys aligned by `--rename DATASET:OLD=NEW`, and video streams whose
encoder parameters differ from the first dataset's re-encoded to them.

Alignment: each dataset's renames (`edit.renames`) are applied as it is opened (`SourceDataset(renames=...)`);
then every dataset must have the first one's fps, robot_type and feature keys, and the same layout for every
feature (dtype, shape, names: state and action names are their meaning), except a video camera's encoder
parameters: `video.codec`, `video.pix_fmt`, `video.g` (its `info` block) and its resolution. A camera of a later
dataset whose parameters differ from the first's has its episodes decoded and encoded again with the first
dataset's parameters (lerobot's encoder, `recode.CameraEncoders`; resized bilinearly when the resolution
differs), so that every episode of the output stream can be joined by remux; every other stream's packets are
copied. Other `info` keys (`video.crf`, `video.preset`, ...) do not stop a remux: those streams are copied and
the output's `info` is the first dataset's. What cannot be aligned is refused in one line naming both datasets:
`error: B/meta/info.json: fps: 30 differs from A's 10`, `error: B/meta/info.json: features.KEY: in A, not in B
(align keys with --rename B:OLD=KEY)`. The statistics of a re-encoded camera are those of the frames encoded.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from openral_data.edit.ops import (
    EditResult,
    Rewrite,
    Selection,
    first_difference,
    summed_histograms,
    write_selection,
)
from openral_data.edit.recode import CameraEncoders, clip_frames
from openral_data.edit.renames import as_mapping, parse_pair
from openral_data.edit.source import EpisodeData, SourceDataset
from openral_data.errors import DatasetError, UsageError
from openral_data.formats.lerobot_v3.encoder import VideoSettings, parse_codec
from openral_data.formats.lerobot_v3.variants import camera_layout, comparable, feature_info, is_depth
from openral_data.types import CameraShape

ENCODER_KEYS = ("video.codec", "video.pix_fmt", "video.g")


def parse_renames(specs: Sequence[str], datasets: Sequence[Path]) -> list[dict[str, str]]:
    """`--rename DATASET:OLD=NEW` (repeatable) -> one OLD -> NEW mapping per dataset, in order. DATASET is a
    dataset as given on the command line (or the same folder)."""
    pairs: list[list[tuple[str, str]]] = [[] for _ in datasets]
    for spec in specs:
        left, sep, new = spec.partition("=")
        name, colon, old = left.rpartition(":")
        if not sep or not colon:
            raise UsageError(f"--rename: {spec!r} is not DATASET:OLD=NEW")
        pairs[_dataset_index(name, datasets, spec)].append(parse_pair(f"{old}={new}", "--rename"))
    return [as_mapping(p, "--rename") for p in pairs]


def _dataset_index(name: str, datasets: Sequence[Path], spec: str) -> int:
    for i, path in enumerate(datasets):
        if name == str(path) or Path(name).resolve() == path.resolve():
            return i
    given = ", ".join(str(p) for p in datasets)
    raise UsageError(f"--rename: {spec!r}: {name!r} is not one of the datasets merged ({given})")


def merge(
    datasets: Sequence[Path], out: Path, order: str = "input", renames: Sequence[dict[str, str]] = ()
) -> EditResult:
    """Concatenate `datasets`, each with its `renames` applied, re-encoding the streams whose encoder
    parameters differ from the first dataset's; `order="seed"` sorts every episode by its recording seed."""
    if not datasets:
        raise UsageError("merge: give at least one dataset")
    if order not in ("input", "seed"):
        raise UsageError(f"--order: {order!r} is not one of input, seed")
    maps = list(renames) or [{} for _ in datasets]
    sources = [SourceDataset(p, m) for p, m in zip(datasets, maps, strict=True)]
    recode = {src.root: differing_cameras(sources[0], src) for src in sources[1:]}
    recode = {root: names for root, names in recode.items() if names}
    selection: Selection = [(s, e) for s in sources for e in range(s.total)]
    if order == "seed":
        selection.sort(key=lambda se: se[0].seed(se[1]))  # stable: equal seeds keep input order
    details: dict[str, Any] = {}
    if any(maps):
        details["renamed"] = {str(s.root): m for s, m in zip(sources, maps, strict=True) if m}
    if recode:
        details["reencoded"] = {str(root): names for root, names in recode.items()}
    encoders = _Reencoder(sources[0], recode)
    try:
        rewrite = Rewrite(
            transform=encoders.episode if recode else None,
            image_hist=None if recode else summed_histograms(sources),
            details=details,
            aligned=True,
        )
        return write_selection(selection, out, "merge", rewrite=rewrite)
    finally:
        encoders.close()


def differing_cameras(first: SourceDataset, other: SourceDataset) -> list[str]:
    """The video cameras of `other` to re-encode to `first`'s encoder parameters; one line refusing whatever
    else differs (fps, robot_type, a feature present on one side only, a feature's layout), naming both."""
    where = f"{other.root}/meta/info.json"
    for what, mine, theirs in (
        ("fps", first.fps, other.fps),
        ("robot_type", first.info.get("robot_type"), other.info.get("robot_type")),
    ):
        if mine != theirs:
            raise DatasetError(
                f"{where}: {what}: {theirs!r} differs from {first.root}'s {mine!r}", code="dataset.mismatch"
            )
    for key in list(first.features) + [k for k in other.features if k not in first.features]:
        if key not in other.features or key not in first.features:
            has, lacks = (first.root, other.root) if key in first.features else (other.root, first.root)
            hint = (
                f"align keys with --rename {other.root}:OLD={key}" if key in first.features else "rename or remove it"
            )
            raise DatasetError(f"{where}: features.{key}: in {has}, not in {lacks} ({hint})", code="dataset.mismatch")
    a, b = comparable(first.features), comparable(other.features)
    cameras = {key: name for name, key in other.camera_key.items()}
    for key in a:
        if key in cameras and a[key].get("dtype") == b[key].get("dtype") == "video":
            a[key], b[key] = _layout(first.features[key]), _layout(other.features[key])
    found = first_difference(a, b, "features")
    if found is not None:
        raise DatasetError(f"{where}: {found}: differs from {first.root}", code="dataset.mismatch")
    differ = [cameras[key] for key in cameras if _encoder(first.features[key]) != _encoder(other.features[key])]
    for name in differ:
        other.refuse_depth(other.camera_key[name], "re-encoding a depth camera to merge it")
    return differ


def _layout(feature: dict[str, Any]) -> dict[str, Any]:
    """A video feature as it must agree across merged datasets: its names and depth, not shape nor encoder."""
    out = {k: v for k, v in camera_layout(feature).items() if k not in ("shape", "fps")}
    out["is_depth_map"] = is_depth(feature)
    return out


def _encoder(feature: dict[str, Any]) -> tuple[Any, ...]:
    """What decides whether two streams join by remux: codec, pixel format, keyframe interval, resolution."""
    info = feature_info(feature)
    shape = camera_layout(feature).get("shape")
    return (*(info.get(k) for k in ENCODER_KEYS), tuple(shape) if isinstance(shape, list) else shape)


def _settings(src: SourceDataset, key: str) -> VideoSettings:
    """The encoder settings of `src`'s camera `key`, as its `info` block states them (lerobot's defaults else)."""
    info = feature_info(src.features[key])
    try:
        codec = parse_codec(str(info.get("video.codec", "av1")))
    except UsageError:
        raise DatasetError(
            f"{src.root}/meta/info.json: features.{key}.info.video.codec: {info.get('video.codec')!r} is not a codec "
            "this writer encodes (av1, h264, hevc); cannot re-encode streams to it",
            code="dataset.unsupported",
        ) from None
    preset = info.get("video.preset")
    return VideoSettings(
        codec=codec,
        crf=int(info.get("video.crf") or 30),
        g=int(info.get("video.g") or 2),
        preset=preset if isinstance(preset, int | str) else None,
        pix_fmt=str(info.get("video.pix_fmt") or "yuv420p"),
    )


class _Reencoder:
    """Re-encodes, episode by episode, the cameras `recode` names for each source, to the first's parameters."""

    def __init__(self, first: SourceDataset, recode: dict[Path, list[str]]) -> None:
        self.recode = recode
        names = sorted({n for ns in recode.values() for n in ns})
        self.shapes: dict[str, CameraShape] = {n: first.schema.cameras[n] for n in names}
        self.encoders: dict[str, CameraEncoders] = {}
        try:
            for n in names:
                settings = _settings(first, first.camera_key[n])
                problem = settings.size_problem(self.shapes[n].height, self.shapes[n].width)
                if problem:
                    raise DatasetError(f"{first.root}: camera {n}: {problem}", code="dataset.unsupported")
                self.encoders[n] = CameraEncoders({n: self.shapes[n]}, settings, first.fps)
        except BaseException:
            self.close()
            raise

    def episode(self, ep: EpisodeData) -> EpisodeData:
        names = self.recode.get(ep.source, [])
        if not names:
            return ep
        videos, image_stats = dict(ep.videos), dict(ep.image_stats)
        for name in names:
            where = f"{ep.source}: episode {ep.index}: camera {name}"
            frames = clip_frames(ep.videos[name], where, self.shapes[name])
            enc = self.encoders[name].encode({name: frames}, ep.length, where)[name]
            videos[name], image_stats[name] = enc.data, enc.stats.stats()
        return dataclasses.replace(ep, videos=videos, image_stats=image_stats)

    def close(self) -> None:
        for enc in self.encoders.values():
            enc.close()
