"""The sampled frames of a `dtype: image` camera (PNG/JPEG cells in the data parquet), measured like a video
camera's: every `stride`-th frame of an episode decoded, one at a time. A data file's image column is read once
for all its episodes (`ImageColumns` keeps the last file's), so memory is bounded by one data file, as for the
motion pass."""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
import pyarrow as pa
import pyarrow.compute as pc

from openral_data.formats.lerobot_v3 import layout
from openral_data.formats.lerobot_v3.images import decode_image
from openral_data.formats.lerobot_v3.masks import is_mask
from openral_data.formats.parquetfile import read_table


def picture_cameras(info: dict[str, Any]) -> list[str]:
    """The `dtype: image` features holding colour pictures (not segmentation masks)."""
    return [
        k
        for k, f in info.get("features", {}).items()
        if isinstance(f, dict) and f.get("dtype") == "image" and not is_mask(f)
    ]


class ImageColumns:
    """The image columns of the last data file read, for the episodes stored in it."""

    def __init__(self, root: Path, keys: list[str]) -> None:
        self.root, self.keys = root, keys
        self._file: tuple[Path, pa.Table] | None = None

    def frames(self, row: dict[str, Any], key: str, stride: int) -> Iterator[npt.NDArray[np.uint8]]:
        """Frames 0, stride, 2*stride, … of camera `key` in the episode of meta/episodes `row`, as RGB."""
        return self.picked(row, key, stride)

    def picked(self, row: dict[str, Any], key: str, wanted: int | Sequence[int]) -> Iterator[npt.NDArray[np.uint8]]:
        """Frames `wanted` (a stride: 0, stride, 2*stride, …; or indices, ascending, those past the episode left
        out) of camera `key` in the episode of meta/episodes `row`, as RGB; only those decoded."""
        path = layout.data_path(self.root, layout.FilePos(int(row["data/chunk_index"]), int(row["data/file_index"])))
        if self._file is None or self._file[0] != path:
            self._file = (path, read_table(path, columns=["episode_index", "frame_index", *self.keys]))
        table = self._file[1]
        episode = table.filter(pc.equal(table.column("episode_index"), int(row["episode_index"])))
        cells = episode.sort_by("frame_index").column(key)
        source = f"{path}: {key}: episode {row['episode_index']}"
        for t in range(0, len(cells), wanted) if isinstance(wanted, int) else (t for t in wanted if t < len(cells)):
            yield decode_image(cells[t].as_py(), f"{source}: frame {t}")
