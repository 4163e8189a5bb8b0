"""Every command over every v3 layout variant lerobot 0.6.1 loads (tests/support/variants.py: a dataset lerobot's
own writer made, altered as older lerobot or other tools wrote it): `info`, `doctor --deep`, `stats`, `tasks list`
read it; `episodes delete/split/merge`, `features remove`, `tasks rename` and `stats recompute` write datasets
lerobot loads with exactly the source's frames, keeping the source's spelling of what they copy (a file they write
anew is in the current lerobot form); `convert` goes to MCAP and back; `push` sends it. Sources stay unchanged."""

from __future__ import annotations

import json
import shutil
from pathlib import Path
from typing import Any

import pyarrow.parquet as pq
import pytest

from openral_data.doctor import check
from openral_data.formats.lerobot_v3.variants import task_is_index
from tests.support.cli import run_cli
from tests.support.inproc import run_inproc
from tests.support.lerobot_written import (
    DEPTH_CAMERA,
    VIDEO_CAMERA,
    Frame,
    digest,
    loaded_episodes,
    same_frames,
    write_lerobot_dataset,
)
from tests.support.variants import VARIANTS, legacy_depth

TASK = "push the block"


@pytest.fixture(scope="module")
def base(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("variants") / "lerobot"
    write_lerobot_dataset(root, with_success=True, image_camera=True)
    return root


@pytest.fixture(scope="module")
def want(base: Path) -> list[list[Frame]]:
    return loaded_episodes(base)


# what `convert` and `push` read differently per variant (the others read as the dataset lerobot wrote)
CONVERTED = {"old-tasks", "channel-names", "video-info", "names-forms", "channel-first"}
PUSHED = {"old-tasks", "no-stats"}


def _made(name: str, base: Path, folder: Path) -> Path:
    """A copy of `base` altered as variant `name`, at `folder/name/ds`."""
    root = folder / name / "ds"
    shutil.copytree(base, root)
    VARIANTS[name](root)
    return root


@pytest.fixture(scope="module", params=list(VARIANTS))
def variant(request: pytest.FixtureRequest, base: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A copy of `base` altered as the variant; read-only to the tests (writing commands write elsewhere)."""
    return _made(request.param, base, tmp_path_factory.mktemp("variant"))


def _ok(*args: str) -> str:
    done = run_inproc(*args)
    assert done.returncode == 0, done.stderr
    return done.stdout


def test_lerobot_loads_the_variant(variant: Path, want: list[list[Frame]]) -> None:
    same_frames([f for e in loaded_episodes(variant) for f in e], [f for e in want for f in e])


def test_reading_commands(variant: Path) -> None:
    before = digest(variant)
    assert json.loads(_ok("info", str(variant), "--json"))["tasks"] == [TASK]
    _ok("doctor", str(variant), "--deep")
    _ok("stats", str(variant))
    table = _ok("stats", str(variant), "--sql", "SELECT task_index, task FROM tasks")
    assert any(line.split("│")[1:3] == [" 0          ", f" {TASK} "] for line in table.splitlines()), table
    assert TASK in _ok("tasks", "list", str(variant))
    _ok("doctor", str(variant), "--repair")  # nothing to repair: an older layout is not rewritten into another
    assert digest(variant) == before


def _source_spelling(variant: Path, out: Path) -> None:
    """An edit copies info.json's features verbatim (names, `video_info`); tasks.parquet it writes anew, in the
    current form (the task as the pandas index `task`)."""
    src = json.loads((variant / "meta/info.json").read_text())["features"]
    got = json.loads((out / "meta/info.json").read_text())["features"]
    assert got[VIDEO_CAMERA] == src[VIDEO_CAMERA]
    assert got["observation.state"]["names"] == src["observation.state"]["names"]
    schema = pq.read_schema(out / "meta/tasks.parquet")
    assert task_is_index(schema) and "task" in schema.names


def _no_success(episodes: list[list[Frame]]) -> list[list[Frame]]:
    return [[{**f, "success": None} for f in e] for e in episodes]


@pytest.mark.slow
def test_edits_give_what_lerobot_loads_frame_exact(variant: Path, want: list[list[Frame]], tmp_path: Path) -> None:
    before = digest(variant)
    out = {k: tmp_path / k for k in ("del", "merge", "feat", "rec", "ren")}
    _ok("episodes", "delete", str(variant), "--episodes", "1", "--out", str(out["del"]))
    _ok("episodes", "split", str(variant), "--episodes", "2,0", "--out", str(tmp_path / "part"))
    _ok("episodes", "merge", str(variant), str(out["del"]), "--out", str(out["merge"]))
    _ok("features", "remove", str(variant), "--feature", "next.success", "--out", str(out["feat"]))
    _ok("stats", "recompute", str(variant), "--out", str(out["rec"]))
    _ok("tasks", "rename", str(variant), "--from", TASK, "--to", "push it", "--out", str(out["ren"]))
    assert digest(variant) == before
    expected = {
        "del": [want[0], want[2]],
        "merge": [*want, want[0], want[2]],
        "feat": _no_success(want),
        "rec": want,
        "ren": [[{**f, "task": "push it"} for f in e] for e in want],
    }
    assert check(tmp_path / "part") == []
    for name, root in out.items():
        assert check(root) == [], name
        got = loaded_episodes(root)
        assert len(got) == len(expected[name]), name
        for g, w in zip(got, expected[name], strict=True):
            same_frames(g, w)
        _source_spelling(variant, root)
    stats = json.loads((out["rec"] / "meta/stats.json").read_text())
    assert {"action", "observation.state", VIDEO_CAMERA} <= stats.keys()  # recomputed, whatever the source had


@pytest.mark.slow
def test_merge_across_variants(base: Path, want: list[list[Frame]], tmp_path: Path) -> None:
    """Datasets that differ only in how they spell a layout merge (the first one's spelling is kept)."""
    sources = []
    for name in ("channel-names", "video-info", "old-tasks"):
        root = tmp_path / name
        shutil.copytree(base, root)
        VARIANTS[name](root)
        sources.append(str(root))
    _ok("episodes", "merge", *sources, str(base), "--out", str(tmp_path / "merged"))
    got = loaded_episodes(tmp_path / "merged")
    assert len(got) == 4 * len(want)
    for g, w in zip(got, want * 4, strict=True):
        same_frames(g, w)
    _source_spelling(tmp_path / "channel-names", tmp_path / "merged")


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(CONVERTED))
def test_convert_to_mcap_and_back(name: str, base: Path, want: list[list[Frame]], tmp_path: Path) -> None:
    variant = _made(name, base, tmp_path)
    bags, back = tmp_path / "bags", tmp_path / "back"
    _ok("convert", str(variant), str(bags), "--image-format", "png")
    _ok("convert", str(bags), str(back), "--codec", "h264")
    got = loaded_episodes(back)

    def kept(episodes: list[list[Frame]]) -> list[list[Any]]:
        return [[(f["state"], f["action"], f["task"]) for f in e] for e in episodes]

    assert kept(got) == kept(want)


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(PUSHED))
def test_push(name: str, base: Path, tmp_path: Path) -> None:
    variant = _made(name, base, tmp_path)
    from tests.support.hub_endpoint import local_hub

    env = {"HF_ENDPOINT": "", "HF_TOKEN": "hf_test_token", "HF_HUB_OFFLINE": "0"}
    with local_hub() as (endpoint, received):
        done = run_cli("push", str(variant), "me/mock", env={**env, "HF_ENDPOINT": endpoint})
    assert done.returncode == 0, done.stderr
    [commit] = received.commits
    sent = commit["files"]
    assert sent["meta/tasks.parquet"] == (variant / "meta/tasks.parquet").read_bytes()  # sent as it is
    assert TASK in sent["README.md"].decode()


REBOT = "v30early_rebot_b601_state_only"  # tests/fixtures/lerobot/README.md: an early-v3 dataset lerobot < 0.5 wrote


@pytest.mark.slow
def test_real_early_v3_dataset(tmp_path: Path) -> None:
    """A real dataset older lerobot wrote (its task in `__index_level_0__`), read and edited by every command."""
    from tests.support.real_datasets import copy_real, real_root

    if real_root(REBOT) is None:
        pytest.skip(f"real fixture {REBOT} is not present (tests/fixtures/lerobot/README.md)")
    src = copy_real(REBOT, tmp_path)
    before = digest(src)
    assert json.loads(_ok("info", str(src), "--json"))["tasks"] == ["pick and place"]
    _ok("doctor", str(src), "--deep")
    _ok("stats", str(src))
    assert "pick and place" in _ok("tasks", "list", str(src))
    _ok("episodes", "merge", str(src), str(src), "--out", str(tmp_path / "merged"))
    _ok("stats", "recompute", str(src), "--out", str(tmp_path / "rec"))
    _ok("convert", str(src), str(tmp_path / "bags"))
    assert digest(src) == before
    assert check(tmp_path / "merged") == [] and check(tmp_path / "rec") == []
    merged = json.loads(_ok("info", str(tmp_path / "merged"), "--json"))
    assert (merged["episodes"], merged["tasks"]) == (2, ["pick and place"])
    _lerobot_sample_equal(tmp_path / "rec", src)


def _lerobot_sample_equal(got: Path, want: Path) -> None:
    """lerobot loads `got` with `want`'s length and, at a sample of frames, its values (a whole load of a real
    dataset's hundreds of frames takes lerobot tens of seconds)."""
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    a, b = (LeRobotDataset("local/check", root=r, video_backend="pyav") for r in (got, want))
    assert len(a) == len(b)
    for i in (0, len(b) // 2, len(b) - 1):
        x, y = a[i], b[i]
        assert x.keys() == y.keys() and x["task"] == y["task"]
        assert all(str(x[k]) == str(y[k]) for k in x), i


@pytest.fixture(scope="module", params=["is_depth_map", "video.is_depth_map"])
def depth(request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A lerobot-written dataset with a depth video camera, flagged as lerobot writes it or the legacy way."""
    root = tmp_path_factory.mktemp("depth") / "ds"
    write_lerobot_dataset(root, with_success=True, depth_camera=True)
    if request.param == "video.is_depth_map":
        legacy_depth(root)
    return root


def _depth_frames(root: Path) -> list[Any]:
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    ds = LeRobotDataset("local/check", root=root, video_backend="pyav")
    return [(ds[i][DEPTH_CAMERA].numpy().tolist(), ds[i]["task"]) for i in range(len(ds))]


@pytest.mark.slow
def test_depth_cameras_are_edited_by_copy(depth: Path, tmp_path: Path) -> None:
    """Edits that copy a depth camera's packets and statistics work; those that would compute its statistics or
    encode it (`stats recompute`, `videos reencode`) are refused in one line, nothing written."""
    before = digest(depth)
    assert json.loads(_ok("info", str(depth), "--json"))["tasks"] == [TASK]
    _ok("doctor", str(depth), "--deep")
    _ok("episodes", "delete", str(depth), "--episodes", "1", "--out", str(tmp_path / "del"))
    _ok("episodes", "merge", str(depth), str(tmp_path / "del"), "--out", str(tmp_path / "merged"))
    for args in (["stats", "recompute"], ["videos", "reencode", "--codec", "h264"]):
        done = run_inproc(*args, str(depth), "--out", str(tmp_path / "refused"))
        assert done.returncode == 2 and done.stderr.startswith("error: "), done.stderr
        assert f"features.{DEPTH_CAMERA}: " in done.stderr and "not supported yet" in done.stderr
        assert not (tmp_path / "refused").exists()
    assert digest(depth) == before
    want = _depth_frames(depth)
    lengths = [6, 9, 4]
    kept = want[:6] + want[15:]
    assert check(tmp_path / "merged", deep=True) == []
    assert _depth_frames(tmp_path / "merged") == want + kept and len(kept) == lengths[0] + lengths[2]
    feature = json.loads((tmp_path / "merged/meta/info.json").read_text())["features"][DEPTH_CAMERA]
    assert feature == json.loads((depth / "meta/info.json").read_text())["features"][DEPTH_CAMERA]
