"""RLDS / TFDS build folders (Open X-Embodiment): split by tfrecord shard; the starting mapping from the
observation pictures and vectors, `steps/action`, the language instruction, reward and is_terminal
(`array_mapping.rlds_mapping`)."""

from __future__ import annotations

from pathlib import Path

from openral_data.convert.kinds.arrays import ArrayKind, LayoutMapping
from openral_data.formats.episodic import ArrayEpisode, ArraySource


class RldsKind(ArrayKind):
    name = "rlds"
    summary = "RLDS / TFDS build folders (features.json, dataset_info.json, tfrecord shards)"
    layouts = ("rlds",)

    def open(self, path: Path) -> ArraySource | None:
        from openral_data.formats.rlds import detect

        return detect(path)

    def blocks(self, handle: ArraySource) -> list[Path]:
        return list(getattr(handle, "shards"))  # noqa: B009 - an RldsSource's

    def open_block(self, src: Path, files: list[Path]) -> ArraySource | None:
        from openral_data.formats.rlds import RldsSource, detect

        whole = detect(src)
        return RldsSource(whole.path, shards=files) if whole is not None else None

    def layout_mapping(self, source: ArraySource, first: ArrayEpisode) -> LayoutMapping:
        from openral_data.convert.array_mapping import rlds_mapping

        return rlds_mapping(source, first)
