"""Zarr replay buffers (diffusion policy's `ReplayBuffer`, UMI): a `.zarr` folder or `.zarr.zip`; one block
(a store is not split); the starting mapping from `data/action` (else UMI's derived action), `data/state`
(else the float vectors) and the pictures (`array_mapping.zarr_mapping`)."""

from __future__ import annotations

from pathlib import Path

from openral_data.convert.kinds.arrays import ArrayKind, LayoutMapping
from openral_data.formats.episodic import ArrayEpisode, ArraySource


class ZarrKind(ArrayKind):
    name = "zarr"
    summary = "Zarr replay buffers (diffusion policy, UMI): a .zarr folder or .zarr.zip"
    layouts = ("zarr",)

    def open(self, path: Path) -> ArraySource | None:
        from openral_data.formats.zarr_replay import detect  # zarr only when a source is looked at

        return detect(path)

    def open_block(self, src: Path, files: list[Path]) -> ArraySource | None:
        return self.open(src)

    def layout_mapping(self, source: ArraySource, first: ArrayEpisode) -> LayoutMapping:
        from openral_data.convert.array_mapping import zarr_mapping

        return zarr_mapping(source, first)
