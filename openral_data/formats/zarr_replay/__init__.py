"""Zarr replay buffers, the layout diffusion policy's `ReplayBuffer` and UMI write: every per-step array under
``data/`` (all episodes' rows concatenated), ``meta/episode_ends`` (the exclusive end row of each episode), in a
zarr v2 (or v3) directory store or a zip store (``*.zarr.zip``, as UMI writes). Read with the `zarr` library, one
row range at a time, as an `ArraySource` (layout ``zarr``; these files store no frame rate, so `fps` is None and
the mapping gives it).
"""

from openral_data.formats.zarr_replay.reader import ZarrReplaySource, detect

__all__ = ["ZarrReplaySource", "detect"]
