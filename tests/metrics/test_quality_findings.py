"""`quality DATASET --episode N` (one episode's findings), the compact `quality` table at 80 and 100 columns,
and `--where` naming one check on one dimension (`quality.findings`) or querying `quality_findings`."""

from __future__ import annotations

import json
from pathlib import Path

import pyarrow.parquet as pq
import pytest

from openral_data.edit.select import matching_episodes
from openral_data.metrics.quality import quality_of
from openral_data.metrics.sources import open_dataset
from tests.support import quality as q
from tests.support.home import isolated_home
from tests.support.inproc import run_inproc

N = 60
FROZEN_FROM = 25  # episode 1: state j1 held from frame 25 while the others move
BLACK = (20, 35)  # episode 2: camera frames 20..34 black

SUMMARY = """\
quality
┏━━━━━━━━━┳━━━━━━━━━━┳━━━━━━━━━┳━━━━━━━━━━━━━━━━━━━━━━━━━━┓
┃ dataset ┃ episodes ┃ flagged ┃ flags                    ┃
┡━━━━━━━━━╇━━━━━━━━━━╇━━━━━━━━━╇━━━━━━━━━━━━━━━━━━━━━━━━━━┩
│ ds      │ 3        │ 2       │ frozen 1, camera_black 1 │
└─────────┴──────────┴─────────┴──────────────────────────┘
episodes
┏━━━━━━━━━┳━━━━━━━━━┳━━━━━━━━━━━━━━┳━━━━━━━━┓
┃ dataset ┃ episode ┃ flags        ┃ frames ┃
┡━━━━━━━━━╇━━━━━━━━━╇━━━━━━━━━━━━━━╇━━━━━━━━┩
│ ds      │ 1       │ frozen       │ 25-59  │
│ ds      │ 2       │ camera_black │ 18-32  │
└─────────┴─────────┴──────────────┴────────┘
"""

EPISODE_1 = """\
findings
┏━━━━━━━━━━━━━━━━━┳━━━━━━━━━━━━━━━━━━━━━━━┳━━━━━━━━┳━━━━━━━┳━━━━━━━━━━━┓
┃ check           ┃ subject               ┃ frames ┃ value ┃ threshold ┃
┡━━━━━━━━━━━━━━━━━╇━━━━━━━━━━━━━━━━━━━━━━━╇━━━━━━━━╇━━━━━━━╇━━━━━━━━━━━┩
│ constant (info) │ observation.state[j1] │ 25-59  │ 35    │ 10        │
│ frozen          │ observation.state[j1] │ 25-59  │ 35    │ 10        │
└─────────────────┴───────────────────────┴────────┴───────┴───────────┘
"""


@pytest.fixture(scope="module")
def dataset(tmp_path_factory: pytest.TempPathFactory) -> Path:
    eps = [q.moving(N, seed) for seed in range(3)]
    eps[1].state[FROZEN_FROM:, 1] = eps[1].state[FROZEN_FROM, 1]
    eps[2].images[BLACK[0] : BLACK[1]] = 0
    return q.write(tmp_path_factory.mktemp("findings") / "ds", eps)


def _out(monkeypatch: pytest.MonkeyPatch, columns: int, *args: str) -> str:
    monkeypatch.setenv("COLUMNS", str(columns))
    run = run_inproc(*args)
    assert run.returncode == 0, run.stderr
    assert max(len(line) for line in run.stdout.splitlines()) <= columns
    return "".join(line.rstrip() + "\n" for line in run.stdout.splitlines())


def test_quality_table_and_one_episode_fit_80_and_100_columns(dataset: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The counts name the raised flags, each flagged episode its frame spans (the black camera, sampled every
    5th frame, is placed within 2 frames of 20..34); `--episode 1` lists its findings with their frames."""
    for columns in (80, 100):
        assert _out(monkeypatch, columns, "quality", str(dataset)) == SUMMARY
        assert _out(monkeypatch, columns, "quality", str(dataset), "--episode", "1") == EPISODE_1
    monkeypatch.setenv("COLUMNS", "80")
    run = run_inproc("quality", str(dataset), "--episode", "7")
    assert run.returncode == 2 and "--episode: 7: no such episode in ds (3 episodes)" in run.stderr


def test_where_names_one_check_on_one_dimension(dataset: Path) -> None:
    assert matching_episodes(dataset, "list_contains(quality.findings, 'frozen:observation.state[j1]')") == [1]
    assert matching_episodes(dataset, "NOT list_contains(quality.findings, 'frozen:observation.state[j1]')") == [0, 2]
    assert matching_episodes(dataset, "list_contains(quality.findings, 'frozen:observation.state[j0]')") == []
    assert matching_episodes(dataset, "list_contains(quality.findings, 'camera_black:observation.images.cam')") == [2]
    sql = (
        "episode_index IN (SELECT episode_index FROM quality_findings WHERE \"check\" = 'frozen' "
        "AND subject = 'observation.state[j1]' AND start_frame <= 30)"
    )
    assert matching_episodes(dataset, sql) == [1]


def test_findings_view_in_stats_sql(dataset: Path) -> None:
    sql = 'SELECT episode_index, "check", subject, start_frame, end_frame FROM quality_findings WHERE flag ORDER BY 1'
    run = run_inproc("stats", str(dataset), "--sql", sql, "--format", "json")
    assert run.returncode == 0, run.stderr
    assert [tuple(r.values()) for r in json.loads(run.stdout)["sql"]] == [
        (1, "frozen", "observation.state[j1]", FROZEN_FROM, N - 1),
        (2, "camera_black", "observation.images.cam", 18, 32),
    ]


def test_recorded_mock_episodes_raise_nothing(tmp_path: Path) -> None:
    """The mock scene's random rSkill (kind `random`: its actions are noise by design) over solid-colour
    cameras: no flag (the old measures raised frozen, jerky, chatter, camera_black and camera_blurred on every
    episode); the state's episode number, constant in each episode, is only `constant`."""
    out = tmp_path / "ds"
    with isolated_home(tmp_path):
        run = run_inproc("record", "--n-episodes", "2", "--max-steps", "40", "--codec", "h264", "--out", str(out))
    assert run.returncode == 0, run.stderr
    got = quality_of(open_dataset(out))
    assert [(r["flags"], r["data_kind"]) for r in got.table.to_pylist()] == [([], "random")] * 2
    found = pq.read_table(got.paths.findings).to_pylist()
    assert {(f["check"], f["subject"], f["flag"]) for f in found} == {("constant", "observation.state[joint2]", False)}
    shown = run_inproc("quality", str(out))  # a person is told nothing was flagged, not shown an empty grid
    assert shown.returncode == 0, shown.stderr
    assert shown.stdout.rstrip().endswith("episodes: none flagged (--all lists every episode)")
    assert "(none)" not in shown.stdout
