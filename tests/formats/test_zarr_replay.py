"""Zarr replay buffers (diffusion policy / UMI) read through the episodic protocol: every value equals what zarr
itself reads from the same store, and a malformed store is one `DatasetError` line naming the file and key."""

from __future__ import annotations

import shutil
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import zarr

from openral_data.errors import DatasetError
from openral_data.formats.zarr_replay import ZarrReplaySource, detect
from tests.support.array_sources import assert_one_line, damaged, read_all
from tests.support.replay_buffer import (
    DAMAGES,
    corrupt_chunk,
    sample_episodes,
    write_replay_buffer,
    write_umi_buffer,
)


@pytest.fixture(scope="module")
def buffer(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return write_replay_buffer(tmp_path_factory.mktemp("rb") / "pusht.zarr", sample_episodes())


def _independent(store: Path | zarr.storage.ZipStore) -> tuple[dict[str, np.ndarray], list[int]]:
    root: Any = zarr.open_group(store if isinstance(store, zarr.storage.ZipStore) else str(store), mode="r")
    return {f"data/{k}": np.asarray(a[:]) for k, a in root["data"].arrays()}, [
        int(e) for e in root["meta/episode_ends"][:]
    ]


@pytest.mark.parametrize("zip_store", [False, True], ids=["directory", "zip"])
def test_every_value_equals_zarr(tmp_path: Path, zip_store: bool) -> None:
    path = tmp_path / ("b.zarr.zip" if zip_store else "b.zarr")
    write_replay_buffer(path, sample_episodes(), zip_store=zip_store)
    store = zarr.storage.ZipStore(path, mode="r") if zip_store else path
    arrays, ends = _independent(store)
    source = detect(path)
    assert isinstance(source, ZarrReplaySource) and source.layout == "zarr" and source.fps is None
    episodes = list(source.episodes())
    assert [e.length for e in episodes] == list(np.diff([0, *ends]))
    start = 0
    for ep, end in zip(episodes, ends, strict=True):
        assert {s.key for s in ep.specs()} == set(arrays)
        for spec in ep.specs():
            want = arrays[spec.key][start:end]
            assert (spec.dtype, spec.shape, spec.encoding) == (want.dtype.name, want.shape[1:], "raw")
            half = ep.length // 2  # two bounded reads make the whole episode
            got = np.concatenate([ep.read(spec.key, 0, half), ep.read(spec.key, half, ep.length)])
            assert got.dtype == want.dtype and np.array_equal(got, want)
        start = end
    source.close()


def test_a_umi_jpegxl_zip_store_equals_zarr(tmp_path: Path) -> None:
    """UMI's images, JPEG-XL compressed one frame a chunk in a zip store: decoded through imagecodecs' numcodecs
    codec, the same pixels zarr gives."""
    episodes = [{"camera0_rgb": ep["img"], "robot0_eef_pos": ep["state"][:, :3]} for ep in sample_episodes((4, 6))]
    path = write_umi_buffer(tmp_path / "dataset.zarr.zip", episodes)
    arrays, ends = _independent(zarr.storage.ZipStore(path, mode="r"))
    source = detect(path)
    assert source is not None
    got = np.concatenate([ep.read("data/camera0_rgb", 0, ep.length) for ep in source.episodes()])
    assert ends == [4, 10] and np.array_equal(got, arrays["data/camera0_rgb"])
    source.close()


def test_a_zarr_v3_store_is_read_too(tmp_path: Path) -> None:
    """The same layout written in zarr's v3 format (zarr.json documents, zarr 3's own codecs)."""
    root: Any = zarr.open_group(str(tmp_path / "v3.zarr"), mode="w", zarr_format=3)
    state = np.arange(24, dtype=np.float32).reshape(8, 3)
    root.create_group("data").create_array("state", data=state, chunks=(3, 3))
    root.create_group("meta").create_array("episode_ends", data=np.array([5, 8], dtype=np.int64))
    source = detect(tmp_path / "v3.zarr")
    assert source is not None
    got = [ep.read("data/state", 0, ep.length) for ep in source.episodes()]
    assert np.array_equal(got[0], state[:5]) and np.array_equal(got[1], state[5:])


def test_not_a_zarr_store_is_not_detected(tmp_path: Path) -> None:
    (tmp_path / "x.bag").write_bytes(b"")
    assert detect(tmp_path) is None and detect(tmp_path / "x.bag") is None


@pytest.mark.parametrize("case", list(DAMAGES))
def test_malformed_store_is_one_line(buffer: Path, tmp_path: Path, case: str) -> None:
    bad = damaged(buffer, tmp_path / "bad.zarr", DAMAGES[case][0])
    with pytest.raises(DatasetError) as excinfo:
        read_all(detect(bad))
    assert_one_line(excinfo.value, bad, DAMAGES[case][1])


def test_a_corrupt_chunk_names_file_and_key(buffer: Path, tmp_path: Path) -> None:
    bad = tmp_path / "bad.zarr"
    shutil.copytree(buffer, bad)
    corrupt_chunk(bad)
    source = detect(bad)
    assert source is not None
    episode = next(source.episodes())
    with pytest.raises(DatasetError, match=rf"^{bad}: data/state: cannot read rows of episode 0: ") as excinfo:
        episode.read("data/state", 0, 2)
    assert "\n" not in str(excinfo.value)


def test_a_symlink_out_of_the_store_is_refused(buffer: Path, tmp_path: Path) -> None:
    bad = tmp_path / "bad.zarr"
    shutil.copytree(buffer, bad)
    outside = tmp_path / "secret"
    outside.write_bytes(b"x")
    (bad / "data/state/0.0").unlink()
    (bad / "data/state/0.0").symlink_to(outside)
    with pytest.raises(DatasetError, match="symlink leads outside the store") as excinfo:
        detect(bad)
    assert excinfo.value.code == "dataset.unsafe"
