"""Every edit keeps each surviving episode's `openral.*` columns of meta/episodes (success, seed, initial state and
`openral.episode_info`: who drove it, a HAL's report) as the source has them; `record --workers`, which merges its
workers' shares through the same path, keeps them as one process writes them. A dataset lerobot wrote (none of
those columns) still edits, and lerobot 0.6.1 loads what the edits write."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pyarrow.parquet as pq
import pytest

from openral_data.formats.lerobot_v3 import LeRobotV3Writer
from openral_data.formats.lerobot_v3.features import EPISODE_EXTRA_COLUMNS
from openral_data.runtime.bridge import DatasetBridge
from openral_data.types import Observation
from tests.support import quality as q
from tests.support.home import isolated_home
from tests.support.inproc import run_inproc
from tests.support.lerobot_written import loaded_episodes, same_frames, write_lerobot_dataset
from tests.support.scenes import mock_scene, write_yaml

N = 20
SUCCESS = [True, False, True, True]


def _info(e: int) -> dict[str, Any]:
    return {"operator": f"teleop:op{e}", "hal": {"interventions": e, "verdict": "ok"}}


def _initial(e: int) -> dict[str, Any]:
    return {"object_pose": [0.1 * e, -0.2, 0.03], "randomization": {"textures.table": f"wood{e}"}}


@pytest.fixture(scope="module")
def ours(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Four episodes (seeds 10..13) with an operator, a HAL report and a known initial state each."""
    root = tmp_path_factory.mktemp("meta-kept") / "ds"
    writer = LeRobotV3Writer(root, q.SCHEMA)
    bridge = DatasetBridge(q.SCHEMA, [writer])
    for e, ok in enumerate(SUCCESS):
        ep = q.moving(N, e)
        bridge.begin_episode(seed=10 + e, initial_state=_initial(e))
        for t in range(N):
            obs = Observation(images={"cam": ep.images[t]}, state=ep.state[t], task="task")
            bridge.add_step(obs, ep.action[t], reward=0.0, done=t == N - 1, success=ok and t == N - 1)
        bridge.end_episode(success=ok, info=_info(e))
    bridge.close()
    return root


def _meta(root: Path) -> dict[int, dict[str, Any]]:
    """seed -> the episode's `openral.*` columns (seeds are unique in these datasets)."""
    rows = pq.read_table(root / "meta/episodes").to_pylist()
    return {int(r["openral.seed"]): {k: r.get(k) for k in EPISODE_EXTRA_COLUMNS} for r in rows}


def test_the_source_holds_what_the_test_compares(ours: Path) -> None:
    meta = _meta(ours)
    assert sorted(meta) == [10, 11, 12, 13]
    assert json.loads(meta[11]["openral.episode_info"]) == _info(1)
    assert json.loads(meta[12]["openral.initial_state"]) == _initial(2)


EDITS: dict[str, tuple[list[str], list[int]]] = {  # argv after DATASET (before --out), seeds kept in output order
    "delete": (["episodes", "delete", "{ds}", "--episodes", "1"], [10, 12, 13]),
    "filter": (["episodes", "filter", "{ds}", "--where", "seed <> 12"], [10, 11, 13]),
    "split": (["episodes", "split", "{ds}", "--episodes", "3,0"], [13, 10]),
    "merge-seed": (["episodes", "merge", "{copy}", "{ds}", "--order", "seed"], [10, 11, 12, 13, 20, 21, 22, 23]),
    "trim": (["episodes", "trim", "{ds}", "--frames", "1:2-15"], [10, 11, 12, 13]),
    "resample": (["episodes", "resample", "{ds}", "--fps", "5"], [10, 11, 12, 13]),
    "tasks-set": (["tasks", "set", "{ds}", "--episodes", "2", "--task", "stack"], [10, 11, 12, 13]),
    "features-rename": (
        ["features", "rename", "{ds}", "--from", "observation.images.cam", "--to", "observation.images.front"],
        [10, 11, 12, 13],
    ),
    "stats-recompute": (["stats", "recompute", "{ds}"], [10, 11, 12, 13]),
    "videos-reencode": (["videos", "reencode", "{ds}", "--vcodec", "h264"], [10, 11, 12, 13]),
}


def _shifted(root: Path, out: Path, by: int) -> Path:
    """A copy of `root` (by `stats recompute`) with every seed moved by `by`, so a merge with it has unique seeds."""
    done = run_inproc("stats", "recompute", str(root), "--out", str(out))
    assert done.returncode == 0, done.stderr
    for path in sorted((out / "meta/episodes").glob("*/*.parquet")):
        table = pq.read_table(path)
        i = table.schema.get_field_index("openral.seed")
        seeds = [s + by for s in table.column(i).to_pylist()]
        pq.write_table(table.set_column(i, table.schema.field(i), [seeds]), path)
    return out


@pytest.mark.parametrize("edit", list(EDITS))
def test_every_edit_keeps_the_episodes_openral_columns(ours: Path, tmp_path: Path, edit: str) -> None:
    argv, kept = EDITS[edit]
    src = _meta(ours)
    if "{copy}" in argv:
        copy = _shifted(ours, tmp_path / "copy", 10)
        src |= _meta(copy)
    out = tmp_path / "out"
    args = [a.format(ds=ours, copy=tmp_path / "copy") for a in argv]
    done = run_inproc(*args, "--out", str(out))
    assert done.returncode == 0, done.stderr
    got = _meta(out)
    assert list(got) == kept
    for seed in kept:
        assert got[seed] == src[seed], seed
    assert json.loads(got[kept[0]]["openral.episode_info"])["operator"].startswith("teleop:op")


def test_lerobot_loads_an_edit_that_kept_the_columns(ours: Path, tmp_path: Path) -> None:
    out = tmp_path / "out"
    done = run_inproc("episodes", "delete", str(ours), "--episodes", "0", "--out", str(out))
    assert done.returncode == 0, done.stderr
    want = loaded_episodes(ours)[1:]
    got = loaded_episodes(out)
    assert len(got) == len(want)
    for g, w in zip(got, want, strict=True):
        same_frames(g, w)


@pytest.fixture(scope="module")
def theirs(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("meta-lerobot") / "ds"
    write_lerobot_dataset(root, with_success=True)
    return root


def test_a_dataset_lerobot_wrote_still_edits_unchanged(theirs: Path, tmp_path: Path) -> None:
    """No `openral.*` columns: nothing to carry, none required; the edit is what it was (info absent)."""
    out = tmp_path / "out"
    done = run_inproc("episodes", "delete", str(theirs), "--episodes", "0", "--out", str(out))
    assert done.returncode == 0, done.stderr
    rows = pq.read_table(out / "meta/episodes").to_pylist()
    assert [r["openral.episode_info"] for r in rows] == [None] * len(rows)
    assert [r["openral.seed"] for r in rows] == [None] * len(rows)
    want = loaded_episodes(theirs)[1:]
    got = loaded_episodes(out)
    for g, w in zip(got, want, strict=True):
        same_frames(g, w)


def _record(base: Path, name: str, *extra: str) -> dict[int, dict[str, Any]]:
    """A seeded mock (its initial state is the seed's, whichever worker records it): 2 episodes of 3 steps."""
    spec = mock_scene(success_after=[3, 2], max_steps=3, n_episodes=2, seeded=True, cameras=[("front", 16, 16)])
    scene = write_yaml(base / "scene.yaml", spec)
    out = base / name
    with isolated_home(base):
        done = run_inproc(
            "record", "--scene", str(scene), "--rskill", "random-mock", "--codec", "h264", "--out", str(out), *extra
        )
    assert done.returncode == 0, done.stderr
    return _meta(out)


def test_record_workers_keeps_who_drove_each_episode(tmp_path: Path) -> None:
    """The issue's case: `record --workers 2` gave `openral.episode_info` [None, None]; one process writes the
    operator. The merged shares now hold what one process writes, column by column."""
    one = _record(tmp_path, "one")
    two = _record(tmp_path, "two", "--workers", "2")
    assert two == one
    assert all(json.loads(m["openral.episode_info"])["operator"] == "policy:random-mock" for m in two.values())
