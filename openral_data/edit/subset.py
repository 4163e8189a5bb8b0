"""An episode rewritten to a subset of its frames, for `episodes trim` and `episodes resample`.

`FrameSubset.episode` takes the frames `keep` (ascending source frame indices) of an episode read by
`SourceDataset.episode`: its rows (state, action, reward, task, carried columns) are those frames' rows, the
writer renumbering `frame_index`, `index` and `timestamp` (frame j at j / fps) as it commits the episode; the
episode's terminal flags (`next.done`, `next.success` of its source's last frame) move to its new last frame,
so an episode that ended done or successful still does. Each video camera's clip is cut by `cut.plan` and
`cut.splice` at an unchanged fps: packets copied where the cuts fall on keyframes, the groups of pictures at
other cuts decoded and encoded again with the source's encoder settings (lerobot's, `VideoSettings`), kept only
when every copied frame decodes to exactly the source's pixels; else (or at another fps) every kept frame is
decoded and encoded again at the output fps. Every camera statistic of a changed episode is recomputed from its
kept pixels; numeric statistics are recomputed by the writer from the rows.
An episode `keep` leaves whole (None) is the source's, untouched.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace

import numpy as np
import pyarrow as pa

from openral_data.edit import cut
from openral_data.edit.recode import CameraEncoders, clip_frames
from openral_data.edit.source import EpisodeData, SourceDataset
from openral_data.edit.stats import column_stats_of
from openral_data.formats.lerobot_v3.stats import ImageStatsAccumulator, Stats

Picks = Callable[[EpisodeData], list[int] | None]  # the source frames an episode keeps; None: all, untouched
Progress = Callable[[int, int], None]  # (episodes done, episodes in all)


@dataclass
class Counts:
    """What an operation did to its episodes' videos (reported and written to the `edit` block)."""

    episodes_changed: int = 0
    frames_dropped: int = 0
    clips_copied: int = 0  # camera clips cut by copying packets
    clips_spliced: int = 0  # camera clips copied but for the groups of pictures at a cut, encoded again
    clips_encoded: int = 0  # camera clips whose kept frames were all encoded again
    spliced: list[str] = field(default_factory=list)  # "EPISODE:camera" of the clips spliced
    encoded: list[str] = field(default_factory=list)  # "EPISODE:camera" of the clips encoded again


class FrameSubset:
    """The per-episode step (`ops.Rewrite.transform`) of an operation keeping some frames of every episode."""

    def __init__(self, src: SourceDataset, picks: Picks, fps: int | None = None) -> None:
        self.src, self.picks = src, picks
        self.fps = src.fps if fps is None else fps
        self.counts = Counts()
        for key in src.camera_key.values():  # a depth camera's statistics are not computed by editing yet
            src.refuse_depth(key, "cutting a depth camera's frames")
        self._encoders: dict[str, CameraEncoders] = {}

    def episode(self, ep: EpisodeData) -> EpisodeData:
        keep = self.picks(ep)
        if keep is None:
            return ep
        where = f"{self.src.root}: episode {ep.index}"
        self.counts.episodes_changed += 1
        self.counts.frames_dropped += max(0, ep.length - len(keep))
        videos: dict[str, bytes] = {}
        image_stats: dict[str, Stats] = {}
        for name, mp4 in ep.videos.items():
            videos[name], image_stats[name] = self._clip(ep.index, name, mp4, keep, f"{where}: camera {name}")
        columns = {key: col.take(pa.array(keep, pa.int64())) for key, col in ep.columns.items()}
        column_stats = {
            key: column_stats_of(self.src.features[key], columns[key].to_pylist(), f"{self.src.root}: {key}")[0]
            for key in ep.column_stats
        }
        return replace(
            ep,
            length=len(keep),
            states=ep.states[keep],
            actions=ep.actions[keep],
            rewards=[ep.rewards[k] for k in keep],
            dones=_terminal(ep.dones, keep),
            successes=_terminal(ep.successes, keep),
            tasks=[ep.tasks[k] for k in keep],
            videos=videos,
            image_stats=image_stats,
            columns=columns,
            column_stats=column_stats,
        )

    def _clip(self, index: int, name: str, mp4: bytes, keep: Sequence[int], where: str) -> tuple[bytes, Stats]:
        """One camera's clip of the kept frames and their statistics: packets copied where the cuts fall on
        keyframes, the groups of pictures at other cuts encoded again; at another fps, packets copied when every
        kept frame is a keyframe; else every kept frame encoded again."""
        key = cut.keyframes(mp4, where)
        if self.fps == self.src.fps:
            segments = cut.plan(keep, key)
            fresh = [self._encode(name, mp4, list(range(a, b)), where) for copied, a, b in segments if not copied]
            data = cut.splice(mp4, segments, fresh, self.fps, where)
            stats = None if data is None else _checked_stats(data, mp4, keep, segments, where)
            if data is not None and stats is not None:
                if fresh:
                    self.counts.clips_spliced += 1
                    self.counts.spliced.append(f"{index}:{self.src.camera_key[name]}")
                else:
                    self.counts.clips_copied += 1
                return data, stats
        elif all(key[k] for k in keep):  # another fps, only keyframes kept: their packets are copied
            data = cut.select(mp4, keep, self.fps, where)
            if data is not None:
                self.counts.clips_copied += 1
                return data, _pixel_stats(data, where)
        enc = self._encoders_of(name).encode({name: cut.decoded_frames(mp4, keep, where)}, len(keep), where)[name]
        self.counts.clips_encoded += 1
        self.counts.encoded.append(f"{index}:{self.src.camera_key[name]}")
        return enc.data, enc.stats.stats()

    def _encoders_of(self, name: str) -> CameraEncoders:
        encoders = self._encoders.get(name)
        if encoders is None:
            shape = self.src.schema.cameras[name]
            encoders = self._encoders[name] = CameraEncoders({name: shape}, self.src.video, self.fps)
        return encoders

    def _encode(self, name: str, mp4: bytes, frames: list[int], where: str) -> bytes:
        """The source frames `frames` of a clip (decoded from its start), encoded again as a clip of their own."""
        pictures = cut.decoded_frames(mp4, frames, where)
        return self._encoders_of(name).encode({name: pictures}, len(frames), where)[name].data

    def step(self, progress: Progress | None) -> Callable[[EpisodeData], EpisodeData]:
        """`episode`, reporting each episode done to `progress`."""
        if progress is None:
            return self.episode
        total, done = self.src.total, [0]

        def counted(ep: EpisodeData) -> EpisodeData:
            out = self.episode(ep)
            done[0] += 1
            progress(done[0], total)
            return out

        return counted

    def close(self) -> None:
        for encoders in self._encoders.values():
            encoders.close()


def _terminal(flags: list[bool], keep: Sequence[int]) -> list[bool]:
    """`flags` at the kept frames, the source's last frame's flag carried to the new last frame."""
    out = [bool(flags[k]) for k in keep]
    if out and flags and flags[-1]:
        out[-1] = True
    return out


def _checked_stats(
    data: bytes, mp4: bytes, keep: Sequence[int], segments: list[cut.Segment], where: str
) -> Stats | None:
    """The statistics of a cut clip's frames, once every frame it copied decodes to exactly the source's pixels
    and it holds exactly the kept frames; None otherwise (a splice the decoder did not take as a whole)."""
    if all(flag for flag, _, _ in segments):  # packets only: the source's frames by construction
        return _pixel_stats(data, where)
    acc = ImageStatsAccumulator()
    copied = {k for flag, a, b in segments if flag for k in range(a, b)}
    try:
        for frame, k, want in zip(clip_frames(data, where), keep, cut.decoded_frames(mp4, keep, where), strict=True):
            if k in copied and not np.array_equal(frame, want):
                return None
            acc.add(frame)
    except ValueError:  # zip: the clip does not hold exactly the kept frames
        return None
    return acc.stats()


def _pixel_stats(data: bytes, where: str) -> Stats:
    acc = ImageStatsAccumulator()
    for frame in clip_frames(data, where):
        acc.add(frame)
    return acc.stats()
