"""`--download`: the real huggingface_hub client (`snapshot_download`) fetching a dataset from a local stand-in for
the Hub's HTTP API (tests/support/hub_endpoint.py) into lerobot's cache folder: `meta/` and `data/` only for a
command that reads no pixels, videos when one does, `--revision`/`--include`, a file cut off mid-way resumed by
HTTP Range, a killed download resumed by a rerun, and offline mode and refusals as one line with a code."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from huggingface_hub import constants

from openral_data.errors import HubError
from openral_data.hub import DownloadOptions, fetch_dataset
from tests.support.hub_endpoint import Files, Received, local_hub
from tests.support.inproc import run_inproc
from tests.support.recorded import record_small

VIDEO = "videos/observation.images.front/chunk-000/file-000.mp4"
DATA = "data/chunk-000/file-000.parquet"
TEMPLATE = "/{repo_id}/resolve/{revision}/{filename}"  # huggingface_hub's file URL, after the endpoint


@pytest.fixture(scope="module")
def source(tmp_path_factory: pytest.TempPathFactory) -> Files:
    """A small recorded dataset's files, as the Hub serves them (with the card and .gitattributes it adds)."""
    root = record_small(tmp_path_factory.mktemp("hub_download"))
    files = {
        p.relative_to(root).as_posix(): p.read_bytes()
        for top in ("meta", "data", "videos")
        for p in sorted((root / top).rglob("*"))
        if p.is_file()
    }
    return {**files, "README.md": b"---\nlicense: mit\n---\n", ".gitattributes": b"*.mp4 filter=lfs\n"}


@pytest.fixture
def home(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """lerobot's HF_LEROBOT_HOME for this test (the variable, read where a repo id is resolved)."""
    monkeypatch.setenv("HF_LEROBOT_HOME", str(tmp_path / "lerobot"))
    return tmp_path / "lerobot"


@pytest.fixture
def hub(source: Files, home: Path, monkeypatch: pytest.MonkeyPatch) -> Iterator[tuple[str, Received]]:
    """The stand-in serving `me/ds` (main and the v3.0 tag) as the client's endpoint, with a token."""
    changed = {**source, "meta/info.json": source["meta/info.json"].replace(b'"fps": 20', b'"fps": 21')}
    served = {"me/ds": {"v3.0": source, "main": changed}}
    with local_hub(received=Received(served=served)) as (endpoint, received):
        monkeypatch.setattr(constants, "ENDPOINT", endpoint)
        monkeypatch.setattr(
            constants, "HUGGINGFACE_CO_URL_TEMPLATE", endpoint + "/{repo_id}/resolve/{revision}/{filename}"
        )
        monkeypatch.setattr(constants, "HF_HUB_OFFLINE", False)
        monkeypatch.setenv("HF_TOKEN", "hf_test_token")
        yield endpoint, received


def _tree(root: Path) -> Files:
    return {p.relative_to(root).as_posix(): p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()}


def _only(source: Files, *tops: str) -> Files:
    return {rel: data for rel, data in source.items() if rel.split("/")[0] in tops}


def test_info_downloads_meta_and_data_then_a_pixel_command_adds_the_videos(
    hub: tuple[str, Received], home: Path, source: Files
) -> None:
    _, received = hub
    done = run_inproc("info", "me/ds", "--download")
    assert done.returncode == 0, done.stderr
    target = home / "me" / "ds"
    assert _tree(target) == _only(source, "meta", "data")  # the v3.0 tag's files; no videos, no .cache
    assert sorted(os.listdir(target.parent)) == ["ds"]  # no staging left behind
    assert not any(rel.startswith("videos/") for rel, _ in received.gets)
    assert "episodes" in done.stdout and run_inproc("info", "me/ds").returncode == 0  # cached now, no flag needed
    received.gets.clear()
    done = run_inproc("doctor", "me/ds", "--download")
    assert done.returncode == 0, done.stderr
    assert _tree(target) == _only(source, "meta", "data", "videos")
    assert {rel.split("/")[0] for rel, _ in received.gets} == {"videos"}  # what was there is not fetched again


def test_revision_and_include(hub: tuple[str, Received], home: Path, source: Files) -> None:
    main = hub[1].served["me/ds"]["main"]
    args = ["--download", "--revision", "main", "--include", "data/*", "--include", "README.md"]
    done = run_inproc("stats", "me/ds", *args)
    assert done.returncode == 0, done.stderr
    expected = {**_only(source, "meta", "data"), "README.md": source["README.md"]}
    assert _tree(home / "me" / "ds") == {**expected, "meta/info.json": main["meta/info.json"]}  # main's, not v3.0's
    assert run_inproc("info", "me/other", "--revision", "main").stderr.startswith("error: --revision and --include go")


def test_a_file_cut_off_mid_way_resumes_by_range(
    hub: tuple[str, Received], home: Path, source: Files, monkeypatch: pytest.MonkeyPatch
) -> None:
    _, received = hub
    monkeypatch.setattr(constants, "DOWNLOAD_CHUNK_SIZE", 50)  # the client keeps what it got in 50-byte chunks
    received.cut[DATA] = 100
    fetch_dataset("me/ds", DownloadOptions(videos=False))
    assert _tree(home / "me" / "ds")[DATA] == source[DATA]
    assert [r for rel, r in received.gets if rel == DATA] == ["", "bytes=100-"]


@pytest.mark.parametrize(
    ("refuse", "repo", "code", "words"),
    [
        ({}, "me/nothing", "hub.missing", "no such dataset repo on the Hub, or it is private"),
        ({"refs": 401}, "me/ds", "hub.missing", "no such dataset repo on the Hub, or it is private"),
        ({"refs": 403}, "me/ds", "hub.auth", "a gated dataset; accept its conditions"),
        ({"resolve": 400}, "me/ds", "hub.refused", "the Hub refused the download"),
    ],
)
def test_refusals_are_one_line(
    hub: tuple[str, Received], home: Path, refuse: dict[str, int], repo: str, code: str, words: str
) -> None:
    _, received = hub
    with local_hub(refuse, received) as (endpoint, _):
        constants.ENDPOINT = endpoint
        constants.HUGGINGFACE_CO_URL_TEMPLATE = endpoint + TEMPLATE
        with pytest.raises(HubError) as err:
            fetch_dataset(repo, DownloadOptions(revision="v3.0" if "resolve" in refuse else None))
    assert err.value.code == code and words in str(err.value) and "\n" not in str(err.value)
    assert not (home / repo).exists()


def test_a_repo_path_leaving_the_folder_is_refused(hub: tuple[str, Received], home: Path, source: Files) -> None:
    """Downloaded = untrusted: a tree entry `meta/../../escaped` is refused before anything is written."""
    hub[1].served["me/evil"] = {"v3.0": {**source, "meta/../../escaped": b"x"}}
    with pytest.raises(HubError) as err:
        fetch_dataset("me/evil", DownloadOptions(videos=False))
    assert err.value.code == "hub.refused" and "\n" not in str(err.value) and "answer is refused" in str(err.value)
    assert (
        not (home / "me" / "evil").exists()
        and not (home / "escaped").exists()
        and not (home / "me" / "escaped").exists()
    )


def test_offline_is_one_line(home: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(constants, "HF_HUB_OFFLINE", True)
    done = run_inproc("info", "me/ds", "--download")
    assert done.returncode == 2
    assert done.stderr.splitlines() == [
        "error: me/ds: not in the local cache and HF_HUB_OFFLINE is set; unset it to download"
    ]


@pytest.mark.slow
def test_a_killed_download_never_looks_complete_and_a_rerun_finishes_it(
    hub: tuple[str, Received], home: Path, source: Files
) -> None:
    endpoint, received = hub
    received.hang[VIDEO] = 1000
    env = {**os.environ, "HF_ENDPOINT": endpoint, "HF_HUB_OFFLINE": "0", "HF_LEROBOT_HOME": str(home)}
    child = subprocess.Popen(
        [sys.executable, "-m", "openral_data.cli", "doctor", "me/ds", "--download"],
        env=env,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    try:
        deadline = time.monotonic() + 120
        while VIDEO not in [rel for rel, _ in received.gets] and child.poll() is None:
            assert time.monotonic() < deadline
            time.sleep(0.1)
        time.sleep(0.5)  # the other files finish meanwhile
    finally:
        child.send_signal(signal.SIGKILL)
        child.wait()
    staging = home / "me" / ".ds.download"
    assert not (home / "me" / "ds").exists() and staging.is_dir()  # not in place: it does not look complete
    finished = {rel for rel in _tree(staging) if not rel.startswith(".cache/")}
    assert finished and VIDEO not in finished
    received.hang.clear()
    received.gets.clear()
    fetch_dataset("me/ds", DownloadOptions())
    assert _tree(home / "me" / "ds") == _only(source, "meta", "data", "videos")  # byte-identical
    assert not staging.exists()
    assert not finished & {rel for rel, _ in received.gets}  # what the killed run finished is not fetched again
    # lerobot takes the folder as a local dataset (no `.cache/huggingface/download/` there, which it would take for
    # an old-style mirror and fetch again): offline, `LeRobotDataset("me/ds")` loads it
    load = "from lerobot.datasets.lerobot_dataset import LeRobotDataset as D; print(D('me/ds').num_frames)"
    env = {**os.environ, "HF_LEROBOT_HOME": str(home), "HF_HUB_OFFLINE": "1"}
    loaded = subprocess.run([sys.executable, "-c", load], env=env, capture_output=True, text=True, check=False)
    assert loaded.returncode == 0, loaded.stderr
    assert int(loaded.stdout.split()[-1]) > 0


def test_every_command_taking_a_dataset_has_the_options_push_does_not() -> None:
    import typer.main

    from openral_data.cli.app import app

    root: Any = typer.main.get_command(app)

    def options(*path: str) -> set[str]:
        command = root
        for name in path:
            command = command.commands[name]
        return {opt for p in command.params for opt in p.opts}

    taking = [("info",), ("doctor",), ("view",), ("convert",), ("upgrade",), ("replay",), ("stats", "report")]
    taking += [("stats", "recompute"), ("export",)]
    taking += [("episodes", c) for c in ("delete", "filter", "split", "merge")]
    taking += [("tasks", c) for c in ("list", "rename", "set")] + [("features", "remove")]
    taking += [("videos", c) for c in ("reencode", "encode-images")]
    for path in taking:
        assert {"--download", "--revision", "--include"} <= options(*path), path
    assert "--download" not in options("push") and "--include" not in options("push")
