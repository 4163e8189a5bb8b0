"""`record --workers N`: episodes ordered by seed whichever worker finishes first, both formats, Ray too."""

from __future__ import annotations

import json
from pathlib import Path

import pyarrow.parquet as pq
import pytest
from rosbags.highlevel import AnyReader

from openral_data.doctor import check
from openral_data.errors import OutputExists, UsageError
from openral_data.record.options import RecordOptions
from openral_data.record.parallel.run import record_parallel
from openral_data.record.sim import record
from openral_data.runtime.parallel.executors import run_on
from tests.support.cli import run_cli
from tests.support.probe_worker import Probe, init_probe, probe
from tests.support.scenes import mock_scene, write_yaml
from tests.support.seeded import episode_seeds, verify_seeded_dataset
from tests.support.timing import TIMED

pytestmark = TIMED

LENGTHS = [5, 9, 3, 7, 4, 6]


def _scene(project: Path, step_sleep: list[float] | float = 0.0) -> Path:
    return write_yaml(
        project / "scenes/sim/mock_par.yaml",
        mock_scene(scene_id="mock_par", success_after=LENGTHS, n_episodes=6, seeded=True, step_sleep=step_sleep),
    )


def _bag_episodes(mcap_root: Path) -> list[tuple[str, int, int]]:
    """(bag folder, episode named by its start marker, seed) of every bag."""
    out = []
    for bag in sorted(mcap_root.glob("episode_*")):
        with AnyReader([bag]) as reader:
            conns = [c for c in reader.connections if c.topic == "/openral/episode"]
            first = next(iter(reader.messages(connections=conns)))
            marker = json.loads(reader.deserialize(first[2], first[0].msgtype).data)  # type: ignore[attr-defined]
        out.append((bag.name, int(marker["episode"]), int(marker["seed"])))
    return out


def _table(root: Path, sub: str) -> list[dict[str, object]]:
    return pq.read_table(sorted(root.glob(f"{sub}/*/*.parquet"))[0]).to_pylist()


@pytest.mark.slow
def test_workers_order_episodes_by_seed_not_by_finish(project: Path, tmp_path: Path) -> None:
    # worker 0 (seeds 0-2) sleeps on every step, so worker 1 (seeds 3-5) finishes first
    scene = _scene(project, step_sleep=[0.25, 0.25, 0.25, 0.0, 0.0, 0.0])
    out = tmp_path / "par"
    opts = RecordOptions(scene=str(scene), rskill="random-mock", out=out, codec="h264", formats=("lerobot", "mcap"))
    summary = record_parallel(opts, workers=2)
    assert summary.finish_order == (1, 0)
    assert [(e.index, e.seed, e.length) for e in summary.episodes] == [(k, k, n) for k, n in enumerate(LENGTHS)]
    assert episode_seeds(out) == [0, 1, 2, 3, 4, 5]
    assert _bag_episodes(out / "mcap") == [(f"episode_{k:06d}", k, k) for k in range(6)]
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]  # worker folders are gone
    # the same rows and episode metadata as one process recording the same seeds
    single = record(RecordOptions(scene=str(scene), rskill="random-mock", out=tmp_path / "one", codec="h264"))
    assert single.frames == summary.frames
    assert _table(out, "data") == _table(tmp_path / "one", "data")
    assert _table(out, "meta/episodes") == _table(tmp_path / "one", "meta/episodes")
    # camera stats too: the workers' pixel histograms are summed, not approximated
    assert (out / "meta/stats.json").read_text() == (tmp_path / "one" / "meta/stats.json").read_text()
    assert check(out) == []
    seen = verify_seeded_dataset(out)
    assert seen["lengths"] == LENGTHS
    # the merged dataset carries the recording's settings: --resume continues it with the next seed
    resumed = record(RecordOptions(out=out, resume=True, n_episodes=7, explicit=frozenset({"n_episodes"})))
    assert [e.seed for e in resumed.episodes] == [6]
    assert episode_seeds(out) == [0, 1, 2, 3, 4, 5, 6] and check(out) == []


def test_workers_cli_and_errors(project: Path, tmp_path: Path) -> None:
    scene = _scene(project)
    out = tmp_path / "cli"
    res = run_cli(
        "record", "--scene", str(scene), "--rskill", "random-mock", "--out", str(out), "--codec", "h264",
        "--format", "mcap", "--workers", "2", "--threads-per-worker", "1",
    )  # fmt: skip
    assert res.returncode == 0, res.stderr
    assert "2 (local)" in res.stdout
    assert [b for b, _, _ in _bag_episodes(out / "mcap")] == [f"episode_{k:06d}" for k in range(6)]
    assert not (out / "meta").exists()
    # usage errors share one code; the option named in the wording tells them apart, so it is matched too
    with pytest.raises(UsageError, match="--workers must be >= 1") as excinfo:
        record_parallel(RecordOptions(scene=str(scene), out=tmp_path / "x"), workers=0)
    assert excinfo.value.code == "usage"
    with pytest.raises(UsageError, match="--executor") as excinfo:
        record_parallel(RecordOptions(scene=str(scene), out=tmp_path / "y"), workers=2, executor="dask")
    assert excinfo.value.code == "usage"
    with pytest.raises(OutputExists) as excinfo:
        record_parallel(RecordOptions(scene=str(scene), out=out / "mcap"), workers=2)
    assert excinfo.value.code == "output.exists"


@pytest.mark.slow
def test_ray_executor_on_a_local_instance(project: Path, tmp_path: Path) -> None:
    """A real local Ray instance is started and stopped; episodes come back in seed order, both formats."""
    scene = _scene(project)
    out = tmp_path / "ray"
    opts = RecordOptions(scene=str(scene), rskill="random-mock", out=out, codec="h264", formats=("lerobot", "mcap"))
    summary = record_parallel(opts, workers=2, executor="ray")
    assert sorted(summary.finish_order) == [0, 1]
    assert [(e.index, e.seed, e.length) for e in summary.episodes] == [(k, k, n) for k, n in enumerate(LENGTHS)]
    assert _bag_episodes(out / "mcap") == [(f"episode_{k:06d}", k, k) for k in range(6)]
    assert verify_seeded_dataset(out)["lengths"] == LENGTHS
    import ray

    assert not ray.is_initialized()  # the instance this command started is shut down again


@pytest.mark.slow
def test_interrupted_workers_keep_their_finished_episodes(project: Path, tmp_path: Path) -> None:
    """Ctrl-C during `record --workers 2`: nothing reaches --out, the running worker is stopped at a step
    boundary (not waited for), and every episode a worker finished stays in its own valid dataset."""
    import os
    import signal
    import subprocess
    import sys
    import time

    # worker 0 (seeds 0-2) is quick; worker 1 (seeds 3-5) sleeps 4 s per step (68 s for its share: a loaded
    # machine must not let it finish before worker 0 did; it is stopped at its next step boundary anyway)
    scene = _scene(project, step_sleep=[0.0, 0.0, 0.0, 4.0, 4.0, 4.0])
    out = tmp_path / "par"
    proc = subprocess.Popen(
        [sys.executable, "-m", "openral_data.cli", "record", "--scene", str(scene), "--rskill", "random-mock",
         "--out", str(out), "--codec", "h264", "--workers", "2"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=dict(os.environ),
    )  # fmt: skip
    deadline = time.monotonic() + 240
    while time.monotonic() < deadline:
        infos = list(tmp_path.glob(".par.workers-*/worker-000/meta/info.json"))
        if infos and json.loads(infos[0].read_text())["total_episodes"] == 3:
            break
        time.sleep(0.05)
    else:
        proc.kill()
        pytest.fail("worker 0 did not finish its share in time")
    proc.send_signal(signal.SIGINT)  # the parent only: it must stop worker 1 itself
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 130, err
    assert "Traceback" not in err and "finished episode(s) are kept in" in err, err
    assert not out.exists()
    (workdir,) = tmp_path.glob(".par.workers-*")
    kept = {w.name: json.loads((w / "meta/info.json").read_text())["total_episodes"] for w in workdir.iterdir()}
    assert kept["worker-000"] == 3 and kept.get("worker-001", 0) < 3  # worker 1 was stopped, not waited for
    assert f"the workers' {sum(kept.values())} finished" in err
    for name in kept:
        assert check(workdir / name) == [], name
        assert episode_seeds(workdir / name) == ([0, 1, 2] if name == "worker-000" else [3, 4, 5][: kept[name]])


def test_view_is_refused_with_workers(tmp_path: Path) -> None:
    """A live view watches one process; several workers would each try to serve on the same port."""
    with pytest.raises(UsageError) as err:
        record_parallel(RecordOptions(out=tmp_path / "ds", view=True), 2)
    assert "--view" in str(err.value) and err.value.code == "usage"
    assert not (tmp_path / "ds").exists()


def test_local_workers_start_with_stop_signals_held_then_report() -> None:
    """The parent holds SIGINT/SIGTERM blocked while it starts a worker, so a Ctrl-C during the start cannot kill
    it before its initializer ignores SIGINT; the worker lets them through once its handlers are in place. Each
    job's reports reach the parent before its result, and the parent's own signal mask is as it was."""
    import signal

    before = signal.pthread_sigmask(signal.SIG_BLOCK, [])
    events: list[tuple[str, int]] = []

    def finished(result: Probe) -> None:
        events.append(("finished", result.job))

    results = run_on([0, 1], probe, initializer=init_probe, on_finished=finished, on_report=events.append)
    assert signal.pthread_sigmask(signal.SIG_BLOCK, []) == before
    assert sorted(r.job for r in results) == [0, 1]
    for r in results:
        assert {signal.SIGINT, signal.SIGTERM} <= r.blocked_at_start, r
        assert signal.SIGINT not in r.blocked and signal.SIGTERM not in r.blocked and r.sigint_ignored, r
        assert events.index(("running", r.job)) < events.index(("finished", r.job)), events
    assert sorted(events) == [("finished", 0), ("finished", 1), ("running", 0), ("running", 1)]
