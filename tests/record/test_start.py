"""The concurrent start: the policy loads in a worker thread while the scene is built (and later stepped) on the
main thread; `OPENRAL_SEQUENTIAL_START=1` is the old order; both give the same dataset and the same one-line
errors, the scene's first."""

from __future__ import annotations

import logging
import threading
from pathlib import Path

import pyarrow.parquet as pq
import pytest
import yaml

from openral_data.errors import ConfigError
from openral_data.record.options import RecordOptions
from openral_data.record.sim import record
from openral_data.record.start import SEQUENTIAL_ENV, Started, start
from tests.support.cli import run_cli
from tests.support.lerobot import verify_mock_dataset
from tests.support.scenes import mock_scene, write_yaml

LENGTHS = [4, 7, 2]


class Parts:
    """Fake scene/policy makers that note on which thread each part was made and what was closed."""

    def __init__(self, scene_error: Exception | None = None, policy_error: Exception | None = None) -> None:
        self.scene_error, self.policy_error = scene_error, policy_error
        self.threads: dict[str, threading.Thread] = {}
        self.closed: list[str] = []
        self.policy_started = threading.Event()

    def scene(self) -> str:
        self.threads["scene"] = threading.current_thread()
        self.overlapped = self.policy_started.wait(timeout=5)  # concurrent: the policy load is already under way
        if self.scene_error is not None:
            raise self.scene_error
        return "scene"

    def policy(self) -> str:
        self.threads["policy"] = threading.current_thread()
        self.policy_started.set()
        if self.policy_error is not None:
            raise self.policy_error
        return "policy"

    def run(self) -> Started[str, str]:
        return start(self.scene, lambda s: None, self.policy, self.closed.append, self.closed.append)


def test_policy_loads_beside_the_scene_which_stays_on_the_main_thread(caplog: pytest.LogCaptureFixture) -> None:
    parts = Parts()
    with caplog.at_level(logging.INFO, logger="openral_data"):
        started = parts.run()
    assert parts.overlapped and parts.threads["scene"] is threading.main_thread()
    assert parts.threads["policy"] is not threading.main_thread()
    assert (started.scene, started.policy, started.concurrent) == ("scene", "policy", True)
    [total] = [r for r in caplog.records if hasattr(r, "total_ms")]
    assert total.__dict__["concurrent"] is True and total.__dict__["total_ms"] >= total.__dict__["env_ms"]


def test_sequential_start_is_the_old_order(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv(SEQUENTIAL_ENV, "1")
    parts = Parts()
    parts.policy_started.set = lambda: None  # type: ignore[method-assign]  # (nothing to wait for)
    started = parts.run()
    assert started.concurrent is False
    assert parts.threads == {"scene": threading.main_thread(), "policy": threading.main_thread()}


@pytest.mark.parametrize("sequential", ["", "1"])
def test_errors_come_in_the_old_order_and_close_what_was_made(monkeypatch: pytest.MonkeyPatch, sequential: str) -> None:
    monkeypatch.setenv(SEQUENTIAL_ENV, sequential)
    scene_err, policy_err = ConfigError("scene: broken"), ConfigError("policy: broken")
    for parts, first, closed in (
        (Parts(scene_error=scene_err, policy_error=policy_err), scene_err, []),
        (Parts(scene_error=scene_err), scene_err, [] if sequential else ["policy"]),  # loaded beside it: closed
        (Parts(policy_error=policy_err), policy_err, ["scene"]),
    ):
        if sequential:
            parts.policy_started.set()
        with pytest.raises(ConfigError) as info:
            parts.run()
        assert info.value is first and parts.closed == closed


def _scene(project: Path, success_after: list[int]) -> Path:
    return write_yaml(
        project / "scenes/sim/mock_start.yaml",
        mock_scene(scene_id="mock_start", success_after=success_after, n_episodes=len(success_after)),
    )


def test_sequential_and_concurrent_record_the_same_dataset(
    project: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    scene = str(_scene(project, LENGTHS))
    seen = {}
    for mode in ("", "1"):
        monkeypatch.setenv(SEQUENTIAL_ENV, mode)
        out = tmp_path / f"ds{mode or 'concurrent'}"
        summary = record(RecordOptions(scene=scene, rskill="random-mock", out=out, codec="h264"))
        assert [e.length for e in summary.episodes] == LENGTHS
        data = pq.read_table(out / "data/chunk-000/file-000.parquet").to_pylist()
        seen[mode] = (verify_mock_dataset(out, "pyav"), data)
    assert seen[""] == seen["1"]


def _broken_policy(project: Path) -> str:
    """random-mock's contract run by the sweep policy with a period that is not a number: it fails to load."""
    data = yaml.safe_load((project / "rskills/random-mock/rskill.yaml").read_text())
    data.update(id="broken-sweep", policy="sweep", policy_extras={"period": "slow"})
    write_yaml(project / "rskills/broken-sweep/rskill.yaml", data)
    return "broken-sweep"


@pytest.mark.slow
@pytest.mark.parametrize("sequential", ["", "1"])
def test_a_failing_scene_or_policy_is_one_line_on_both_paths(project: Path, tmp_path: Path, sequential: str) -> None:
    broken_scene = str(_scene(project, [0]))  # the mock refuses it when the scene is built
    good_scene = str(write_yaml(project / "scenes/sim/mock_ok.yaml", mock_scene(scene_id="mock_ok")))
    policy = _broken_policy(project)
    scene_line = f"error: {broken_scene}: scene.params.success_after: needs positive step counts"
    policy_line = "error: rskill broken-sweep: policy_extras.period: expected a number, got 'slow'"
    for scene, rskill, line in (
        (broken_scene, "random-mock", scene_line),
        (good_scene, policy, policy_line),
        (broken_scene, policy, scene_line),  # both broken: the scene's error, as before
    ):
        out = tmp_path / f"out-{len(list(tmp_path.iterdir()))}"
        proc = run_cli(
            "record", "--scene", scene, "--rskill", rskill, "--out", str(out), env={SEQUENTIAL_ENV: sequential}
        )
        assert (proc.returncode, proc.stderr.splitlines()) == (2, [line])
        assert not out.exists()  # nothing left behind
