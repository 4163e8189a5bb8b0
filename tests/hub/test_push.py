"""`push`: the checks before anything is sent, `--dry-run`, and the real huggingface_hub client pushing to a local
stand-in for the Hub's HTTP API (tests/support/hub_endpoint.py): exactly the selected files, byte for byte, and the
card arrive in one commit, then the `v3.0` tag; a missing token, offline mode or an unreachable Hub is one line."""

from __future__ import annotations

import re
import shutil
from pathlib import Path

import pytest

from openral_data.errors import HubError, OpenralError
from openral_data.formats.lerobot_v3.lock import DatasetLock
from openral_data.hub import CardOptions, PushOptions, dataset_card, plan_push, select_files, upload
from tests.support.cli import run_cli
from tests.support.home import REPO
from tests.support.hub_endpoint import local_hub
from tests.support.recorded import record_mock_cli


@pytest.fixture(scope="module")
def recorded(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return record_mock_cli(tmp_path_factory.mktemp("hub_push"), [3, 100])


@pytest.fixture
def ds(recorded: Path, tmp_path: Path) -> Path:
    root = tmp_path / "ds"
    shutil.copytree(recorded, root)
    (root / "mcap").mkdir()
    (root / "mcap" / "episode_000000.mcap").write_bytes(b"bag")
    return root


def _env(endpoint: str, token: str = "hf_test_token", offline: str = "0") -> dict[str, str]:
    return {"HF_ENDPOINT": endpoint, "HF_TOKEN": token, "HF_HUB_OFFLINE": offline}


def _code(exc: pytest.ExceptionInfo[OpenralError]) -> str:
    return exc.value.code


def test_plan_sends_exactly_the_selected_files_and_the_card(ds: Path) -> None:
    plan = plan_push(ds, PushOptions("me/mock", include_mcap=True))
    assert plan.files == select_files(ds, include_mcap=True)
    assert "mcap/episode_000000.mcap" in plan.files
    ops = plan.operations
    assert [op.path_in_repo for op in ops] == [*plan.files, "README.md"]
    for op, rel in zip(ops, plan.files, strict=False):
        assert op.path_or_fileobj == str(ds / rel)
    assert ops[-1].path_or_fileobj == dataset_card(ds, CardOptions("me/mock")).encode()


@pytest.mark.parametrize(
    ("damage", "code", "words"),
    [
        ("busy", "dataset.busy", "push it once it is done"),
        ("journal", "dataset.interrupted", "doctor --repair"),
        ("video", "dataset.invalid", "openral-data doctor"),
    ],
)
def test_refused_before_anything_is_read_for_upload(ds: Path, damage: str, code: str, words: str) -> None:
    if damage == "busy":
        lock = DatasetLock(ds, "test recording").acquire()
    elif damage == "journal":
        (ds / ".openral" / "journal.json").write_text("{}")
    else:
        (ds / "videos" / "observation.images.wrist" / "chunk-000" / "file-000.mp4").unlink()
    try:
        with pytest.raises(OpenralError) as err:
            plan_push(ds, PushOptions("me/mock"))
    finally:
        if damage == "busy":
            lock.release()
    assert _code(err) == code and words in str(err.value)
    assert "\n" not in str(err.value)
    if damage == "video":  # --force pushes what is there
        plan = plan_push(ds, PushOptions("me/mock", force=True))
        assert "videos/observation.images.wrist/chunk-000/file-000.mp4" not in plan.files


@pytest.mark.parametrize("repo_id", ["mock", "a/b/c", "../x", "me/"])
def test_repo_id_must_be_owner_slash_name(ds: Path, repo_id: str) -> None:
    with pytest.raises(OpenralError) as err:
        plan_push(ds, PushOptions(repo_id))
    assert _code(err) == "usage"


def test_dry_run_prints_the_plan_and_sends_nothing(ds: Path) -> None:
    with local_hub() as (endpoint, received):
        done = run_cli("push", str(ds), "me/mock", "--dry-run", env=_env(endpoint))
    assert done.returncode == 0, done.stderr
    assert received.tokens == set() and received.commits == []  # not one request
    lines = done.stdout.splitlines()
    files = select_files(ds)
    size = sum((ds / f).stat().st_size for f in files)
    assert lines[0] == f"would push {ds} to the dataset repo me/mock: {len(files)} files ({size} bytes) + the card"
    assert lines[1 : len(files) + 2] == [*(f"  {f}" for f in files), "  README.md (generated, below)"]
    assert "\n".join(lines[len(files) + 3 :]) + "\n" == dataset_card(ds, CardOptions("me/mock"))


@pytest.mark.parametrize("revision", [None, "dev"])
def test_push_to_a_local_hub(ds: Path, revision: str | None) -> None:
    args = ["push", str(ds), "me/mock", "--private", "--include-mcap", "--license", "mit"]
    args += ["--revision", revision] if revision else []
    with local_hub() as (endpoint, received):
        done = run_cli(*args, env=_env(endpoint))
    assert done.returncode == 0, done.stderr
    rev = revision or "main"
    assert done.stdout.startswith(
        f"pushed {len(select_files(ds, include_mcap=True))} files + the card to me/mock (tag v3.0)"
    )
    assert received.tokens == {"Bearer hf_test_token"}
    assert [(r["name"], r["organization"], r["type"], r.get("visibility")) for r in received.repos] == [
        ("mock", "me", "dataset", "private")
    ]
    assert received.branches == ([rev] if revision else [])
    [commit] = received.commits
    assert commit["repo"] == "me/mock" and commit["revision"] == rev
    expected = {rel: (ds / rel).read_bytes() for rel in select_files(ds, include_mcap=True)}
    expected["README.md"] = dataset_card(ds, CardOptions("me/mock", license="mit")).encode()
    assert commit["files"] == expected  # exactly these files, byte for byte; no .openral/, nothing else
    assert received.tags == [("v3.0", rev)]


def test_no_token_is_one_line(ds: Path) -> None:
    with local_hub() as (endpoint, received):
        done = run_cli("push", str(ds), "me/mock", env=_env(endpoint, token=""))
    assert done.returncode == 2
    assert done.stderr.splitlines() == [
        "error: no Hugging Face token: set HF_TOKEN or run `hf auth login` (a token with write access)"
    ]
    assert received.commits == [] and received.repos == []


def test_offline_mode_is_one_line(ds: Path) -> None:
    with local_hub() as (endpoint, received):
        done = run_cli("push", str(ds), "me/mock", env=_env(endpoint, offline="1"))
    assert done.returncode == 2
    assert done.stderr.splitlines() == ["error: me/mock: HF_HUB_OFFLINE is set; unset it to push"]
    assert received.repos == []


def test_unreachable_hub_is_one_line(ds: Path) -> None:
    with local_hub() as (endpoint, _):
        pass  # the port is closed again: nothing listens there
    done = run_cli("push", str(ds), "me/mock", env=_env(endpoint))
    assert done.returncode == 2
    [line] = done.stderr.splitlines()
    assert line.startswith("error: me/mock: cannot reach the Hub: ")


@pytest.mark.parametrize(
    ("refuse", "code"),
    [
        ({"repos": 401}, "hub.auth"),
        ({"repos": 403}, "hub.auth"),
        ({"repos": 400}, "hub.refused"),
        ({"validate-yaml": 400}, "hub.refused"),  # the card's metadata refused (e.g. an unknown --license)
        ({"commit": 403}, "hub.auth"),
    ],
)
def test_hub_refusal_is_one_error(ds: Path, monkeypatch: pytest.MonkeyPatch, refuse: dict[str, int], code: str) -> None:
    """In process, to read the error code: huggingface_hub's endpoint and offline switch are its import-time
    constants, set here as HF_ENDPOINT and HF_HUB_OFFLINE=0 would set them."""
    from huggingface_hub import constants

    plan = plan_push(ds, PushOptions("me/mock"))
    monkeypatch.setenv("HF_TOKEN", "hf_test_token")
    monkeypatch.setattr(constants, "HF_HUB_OFFLINE", False)
    with local_hub(refuse) as (endpoint, received):
        monkeypatch.setattr(constants, "ENDPOINT", endpoint)
        with pytest.raises(HubError) as err:
            upload(plan)
    assert err.value.code == code
    assert str(err.value).startswith("me/mock: the Hub refused the push: ") and "\n" not in str(err.value)
    assert "refused here" in str(err.value)  # the Hub's own reason is kept
    assert received.commits == []


def test_docs_example_is_the_real_output(recorded: Path, tmp_path: Path) -> None:
    """docs/hub.md's `--dry-run` example, up to its elision, is what the command prints for the same recording
    (the byte count aside: video encoders may differ by a few bytes)."""
    text = (REPO / "docs" / "hub.md").read_text()
    block = text.split("<!-- dry-run:begin -->\n```\n", 1)[1].split("```\n<!-- dry-run:end -->", 1)[0]
    command, *shown = block.splitlines()
    assert shown[-1] == "…"
    shutil.copytree(recorded, tmp_path / "datasets" / "pick")
    with local_hub() as (endpoint, received):
        done = run_cli(*command.removeprefix("$ openral-data ").split(), env=_env(endpoint), cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    real = done.stdout.splitlines()[: len(shown) - 1]

    def bytes_aside(line: str) -> str:
        return re.sub(r"\(\d+ bytes\)", "(N bytes)", line)

    assert [bytes_aside(line) for line in real] == [bytes_aside(line) for line in shown[:-1]]
    assert received.commits == []
