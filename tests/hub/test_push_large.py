"""`push` of a large dataset: several commits (the threshold lowered by `PushOptions.commit_files`), `meta/` and the
card last, `--tags` in the card, progress after each commit, and an interrupted push (the stand-in refuses commits
after a few) that resumes when run again and ends with every file on the "Hub" exactly once; nothing is written
into the dataset. The real huggingface_hub client against tests/support/hub_endpoint.py."""

from __future__ import annotations

import math
import shutil
from collections import Counter
from collections.abc import Iterator
from pathlib import Path

import pytest
import yaml
from huggingface_hub import constants

from openral_data.errors import HubError
from openral_data.hub import CardOptions, PushOptions, dataset_card, plan_push, select_files, upload
from tests.support.hub_endpoint import Received, local_hub
from tests.support.inproc import run_inproc
from tests.support.recorded import record_small

TAGS = ("so101", "sim")


@pytest.fixture(scope="module")
def recorded(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return record_small(tmp_path_factory.mktemp("hub_push_large"))


@pytest.fixture
def ds(recorded: Path, tmp_path: Path) -> Path:
    shutil.copytree(recorded, tmp_path / "ds")
    return tmp_path / "ds"


@pytest.fixture
def hub(monkeypatch: pytest.MonkeyPatch) -> Iterator[Received]:
    """The stand-in as the client's endpoint (huggingface_hub's import-time constants, as HF_ENDPOINT and
    HF_HUB_OFFLINE=0 would set them), with a token."""
    monkeypatch.setenv("HF_TOKEN", "hf_test_token")
    monkeypatch.setattr(constants, "HF_HUB_OFFLINE", False)
    with local_hub() as (endpoint, received):
        monkeypatch.setattr(constants, "ENDPOINT", endpoint)
        yield received


def _expected(ds: Path, tags: tuple[str, ...] = ()) -> dict[str, bytes]:
    files = {rel: (ds / rel).read_bytes() for rel in select_files(ds)}
    return {**files, "README.md": dataset_card(ds, CardOptions("me/big", tags=tags)).encode()}


def _listing(root: Path) -> list[tuple[str, int]]:
    return sorted((p.relative_to(root).as_posix(), p.stat().st_size) for p in root.rglob("*"))


def test_a_large_push_is_several_commits_meta_and_the_card_last(ds: Path, hub: Received) -> None:
    before = _listing(ds)
    plan = plan_push(ds, PushOptions("me/big", tags=TAGS, commit_files=3))
    shown: list[int] = []
    result = upload(plan, shown.append)
    expected = _expected(ds, TAGS)
    assert result.commits == math.ceil(len(expected) / 3) > 1 == len({c["revision"] for c in hub.commits})
    assert [len(c["files"]) for c in hub.commits] == [3] * (result.commits - 1) + [len(expected) % 3 or 3]
    order = [rel for c in hub.commits for rel in c["files"]]
    assert Counter(order) == Counter(expected.keys())  # every file exactly once
    firsts = [i for i, rel in enumerate(order) if rel.startswith("meta/") or rel == "README.md"]
    assert firsts == list(range(len(order) - len(firsts), len(order)))  # meta/ and the card in the last commits
    assert order[-1] == "README.md" and hub.held[("me/big", "main")] == expected
    assert shown == [len(c["files"]) for c in hub.commits]  # progress after each commit
    assert hub.tags == [("v3.0", "main")]
    front = yaml.safe_load(expected["README.md"].decode().split("---\n")[1])
    assert front["tags"] == ["LeRobot", "openral-data", *TAGS]  # lerobot's push_to_hub(tags=...) order
    assert _listing(ds) == before  # nothing written into the dataset


def test_an_interrupted_push_resumes_and_sends_each_file_once(ds: Path, hub: Received) -> None:
    plan = plan_push(ds, PushOptions("me/big", commit_files=2))
    hub.commits_allowed = 2
    with pytest.raises(HubError) as err:
        upload(plan)
    total = math.ceil(len(_expected(ds)) / 2)
    assert err.value.code == "hub.refused" and "\n" not in str(err.value)
    assert f"(2 of {total} commits landed; run the same push again to send the rest)" in str(err.value)
    assert hub.tags == []  # not tagged: the repo is not a complete dataset yet
    hub.commits_allowed = None
    again = upload(plan_push(ds, PushOptions("me/big", commit_files=2)))
    assert again.commits == total
    sent = Counter(rel for c in hub.commits for rel in c["files"])
    assert sent == Counter(_expected(ds).keys()) and len(hub.commits) == total  # nothing sent twice, no empty commit
    assert hub.held[("me/big", "main")] == _expected(ds) and hub.tags == [("v3.0", "main")]


def test_push_tags_from_the_command_line(ds: Path, hub: Received) -> None:
    done = run_inproc("push", str(ds), "me/big", "--tags", "so101", "--tags", "sim", "--tags", "LeRobot")
    assert done.returncode == 0, done.stderr
    assert done.stdout.startswith(f"pushed {len(select_files(ds))} files + the card to me/big (tag v3.0)")
    [commit] = hub.commits
    assert commit["files"]["README.md"] == _expected(ds, TAGS)["README.md"]  # LeRobot once
