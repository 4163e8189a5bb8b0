"""A crash at every step of the writer's episode commits: after each, lerobot 0.6.1 loads the dataset directly
(no recovery first) with exactly the committed episodes, frame-exact; recovery, `doctor` and a resumed writer
then complete it into a dataset equal, frame for frame, to an uninterrupted one.

The driver (tests/support/writer_driver.py) writes `LENGTHS` episodes in a subprocess and numbers its filesystem
mutations (renames, unlinks; tests/support/crash.py); killed at mutation N it exits as SIGKILL would, instead of
doing it. A clean run gives the sequence: which mutations there are, which episodes were reported finished
before each, and which count `meta/info.json` (the commit record: it lands last) held after each. Kill points:
every mutation of the first two commits, of close(), and of any commit shaped unlike the common one (a
consolidation or rotation), plus a stride through the rest. Each run is a child forked from one driver server
(tests/support/forked.py) that imported the writer once: a fresh process from the driver's `main()` on.
"""

from __future__ import annotations

import dataclasses
import json
from collections import Counter
from collections.abc import Iterator
from dataclasses import dataclass
from functools import cache
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from openral_data.doctor import check
from openral_data.formats.lerobot_v3 import LeRobotV3Writer, WriterConfig, layout
from openral_data.formats.lerobot_v3.recovery import recover
from openral_data.runtime.bridge import DatasetBridge
from tests.support.crash import KILLED
from tests.support.forked import Forked
from tests.support.patterned import check_loads, dataset_states, unit_schema, write_episodes
from tests.support.writer_driver import SHAPE, use_megabyte, writer_config

pytestmark = pytest.mark.slow

LENGTHS = [3, 5, 8, 4, 6, 7, 3, 8, 5]
STRIDE = 7  # through the commits not killed at every step; coprime with a commit's usual step count
SLOTS = 4  # each configuration's kill points are dealt over this many tests (pytest-xdist spreads them)


@dataclass(frozen=True)
class Case:
    """A writer configuration (`WriterConfig` fields) and the size of the dataset's states."""

    config: dict[str, int]
    state_dim: int = 4
    mb: int | None = None  # the bytes a writer's "MB" counts (writer_driver.use_megabyte); None: 1 MiB

    def driver_args(self) -> dict[str, Any]:
        return {"config": self.config, "state_dim": self.state_dim, "mb": self.mb}

    def states(self) -> list[np.ndarray]:
        return dataset_states(LENGTHS, self.state_dim)


CASES = {
    "defaults": Case({}),
    # consolidation every 3 episodes, and at data-file rotation: with "1 MB" counted as 20,000 bytes, the data file
    # fills once in this run (episode 6 starts the second) and meta/episodes rotates at each consolidation; the
    # close joins the videos. (It was 6,000 floats a frame against a real MB: the same commits at 3x the CPU.)
    "staged3": Case({"staged_episodes": 3, "data_files_size_in_mb": 1}, state_dim=16, mb=20_000),
}


@dataclass(frozen=True)
class Run:
    """A driver run's output, line by line."""

    lines: tuple[str, ...]

    def mutations(self) -> list[int]:
        return [int(line.split()[1]) for line in self.lines if line.startswith("mutation ")]

    def before(self, n: int) -> tuple[str, ...]:
        """The lines printed before mutation `n` is done (what a run killed at `n` prints)."""
        for k, line in enumerate(self.lines):
            if line.startswith(f"mutation {n} "):
                return self.lines[:k]
        raise AssertionError(f"no mutation {n}")

    @staticmethod
    def reported(lines: tuple[str, ...]) -> int:
        done = [int(line.split()[1]) for line in lines if line.startswith("finished ")]
        assert done == list(range(len(done))), done
        return len(done)

    @staticmethod
    def committed(lines: tuple[str, ...]) -> int:
        counts = [int(line.split()[1]) for line in lines if line.startswith("committed ")]
        return counts[-1] if counts else 0

    @staticmethod
    def journaled(lines: tuple[str, ...]) -> bool:
        """Whether the commit journal was in place (an episode commit past its commit point, not yet cleared)."""
        journal = [line for line in lines if line.startswith("mutation ") and line.endswith(" " + layout.JOURNAL_PATH)]
        return bool(journal) and journal[-1].split()[2] in ("replace", "rename")

    def commits(self) -> list[list[str]]:
        """The mutation lines of each step: before episode 0 is reported, between reports, then close()."""
        steps: list[list[str]] = [[]]
        for line in self.lines:
            if line.startswith("finished "):
                steps.append([])
            elif line.startswith("mutation "):
                steps[-1].append(line)
        return steps


@pytest.fixture(scope="session")  # session: a worker may run other modules' tests between these
def driver() -> Iterator[Forked]:
    """The writer driver's server: each run a process of its own, forked after the imports."""
    with Forked("tests.support.writer_driver") as server:
        yield server


def drive(driver: Forked, root: Path, case: Case, die_at: int | None = None) -> tuple[int, Run, str]:
    args: dict[str, Any] = {"root": str(root), "lengths": LENGTHS, **case.driver_args()}
    if die_at is not None:
        args["die_at"] = die_at
    code, out, err = driver.run(json.dumps(args), timeout=300)
    return code, Run(tuple(out.splitlines())), err


def kill_points(run: Run) -> list[int]:
    """Every mutation of the first two commits, of close() and of unusual commits; a stride through the rest."""
    steps = run.commits()
    commits, close = steps[:-1], steps[-1]
    usual = Counter(len(c) for c in commits[2:]).most_common(1)[0][0] if len(commits) > 2 else 0
    every = [line for k, c in enumerate(commits) if k < 2 or len(c) != usual for line in c] + close
    points = {int(line.split()[1]) for line in every}
    points |= set(run.mutations()[::STRIDE])
    return sorted(points)


@cache
def clean_run(name: str, base: Path, driver: Forked) -> tuple[Run, Path]:
    """The uninterrupted run of configuration `name` (its output and dataset, which lerobot loads), once per
    test process."""
    root = base / f"clean-{name}"
    code, run, err = drive(driver, root, CASES[name])
    assert code == 0, err
    total = run.mutations()
    assert total == list(range(1, len(total) + 1)) and run.lines[-1] == f"mutations {len(total)}", run.lines[-3:]
    assert Run.reported(run.lines) == len(LENGTHS) == Run.committed(run.lines)
    check_loads(root, LENGTHS, CASES[name].states(), shape=SHAPE)
    return run, root


def needs_field(config: dict[str, int]) -> None:
    fields = {f.name for f in dataclasses.fields(WriterConfig)}
    missing = sorted(set(config) - fields)
    if missing:
        pytest.skip(f"WriterConfig has no {', '.join(missing)} field yet (the staged-commit layout)")


@cache
def reference_frames(root: Path) -> list[dict[str, Any]]:
    return frames(root)


def frames(root: Path) -> list[dict[str, Any]]:
    """Every frame as lerobot 0.6.1 loads it, as plain values."""
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    ds = LeRobotDataset("local/unit", root=root, video_backend="pyav")
    out = []
    for i in range(len(ds)):
        item = ds[i]
        out.append({k: v if isinstance(v, str) else v.numpy() for k, v in item.items()})
    return out


def data_table(root: Path) -> pa.Table:
    return pa.concat_tables([pq.read_table(p) for p in layout.data_files(root)])


def assert_same_dataset(root: Path, reference: Path) -> None:
    """Frame for frame (lerobot's view, decoded pixels included), data rows, tasks and statistics."""
    got, want = frames(root), reference_frames(reference)
    assert len(got) == len(want)
    for i, (a, b) in enumerate(zip(got, want, strict=True)):
        assert a.keys() == b.keys(), i
        for key in a:
            assert np.array_equal(a[key], b[key]) if not isinstance(a[key], str) else a[key] == b[key], (i, key)
    assert data_table(root).equals(data_table(reference))
    assert pq.read_table(root / layout.TASKS_PATH).equals(pq.read_table(reference / layout.TASKS_PATH))
    stats, stats_ref = (json.loads((r / layout.STATS_PATH).read_text()) for r in (root, reference))
    assert stats.keys() == stats_ref.keys()
    for key in stats:
        for stat in stats[key]:
            np.testing.assert_allclose(stats[key][stat], stats_ref[key][stat], rtol=1e-9, err_msg=f"{key}/{stat}")


def crash_and_complete(driver: Forked, root: Path, case: Case, n: int, clean: Run, reference: Path) -> str:
    """Kill the driver at mutation `n`; check what lerobot loads, recover, resume, compare. Returns a log line."""
    code, run, err = drive(driver, root, case, die_at=n)
    expect = clean.before(n)
    assert code == KILLED, (n, code, err)
    assert run.lines == expect, f"kill at {n}: the run printed {run.lines[-3:]}, the clean run {expect[-3:]}"
    reported, committed = Run.reported(expect), Run.committed(expect)
    assert committed in (reported, reported + 1), (n, reported, committed)  # info.json lands last
    what = next(line for line in clean.lines if line.startswith(f"mutation {n} "))
    if committed == 0:
        assert not (root / layout.INFO_PATH).exists(), what
    else:
        try:
            check_loads(root, LENGTHS[:committed], case.states(), shape=SHAPE)  # the killed dataset, as it is
        except Exception as exc:
            raise AssertionError(f"killed before {what} ({reported} reported, {committed} committed): {exc!r}") from exc
    recover(root)
    # recovery finishes a commit whose journal was in place; else the dataset stays at info.json's count
    recovered = reported + 1 if Run.journaled(expect) else committed
    if recovered:
        errors = [f.line() for f in check(root) if f.severity == "error"]
        assert errors == [], f"killed before {what}, then recovered: doctor finds {errors}"
    config = writer_config(case.config)
    schema = unit_schema(case.state_dim, SHAPE)
    use_megabyte(case.mb)  # the resumed writer counts sizes as the killed one did
    try:
        writer = LeRobotV3Writer(root, schema, config, resume=True)
        assert writer.total_episodes == recovered, what
        bridge = DatasetBridge(schema, [writer])
        write_episodes(bridge, LENGTHS, first=recovered, state_dim=case.state_dim, shape=SHAPE)
        bridge.close()
    finally:
        use_megabyte(None)
    findings = [f.line() for f in check(root)]
    assert findings == [], f"killed before {what}, recovered and resumed: doctor finds {findings}"
    try:
        assert_same_dataset(root, reference)
    except AssertionError as exc:
        raise AssertionError(
            f"killed before {what}, recovered and resumed: not the uninterrupted dataset: {exc!r}"
        ) from exc
    return f"{what}: {reported} reported, {committed} committed, {recovered} after recovery"


@pytest.mark.parametrize("slot", range(SLOTS))
@pytest.mark.parametrize("name", list(CASES))
def test_crash_at_every_commit_step(
    tmp_path: Path, tmp_path_factory: pytest.TempPathFactory, driver: Forked, name: str, slot: int
) -> None:
    case = CASES[name]
    needs_field(case.config)
    clean, reference = clean_run(name, tmp_path_factory.getbasetemp(), driver)
    log, failures = [], []
    for n in kill_points(clean)[slot::SLOTS]:
        try:
            log.append(crash_and_complete(driver, tmp_path / f"kill-{n}", case, n, clean, reference))
        except Exception as exc:  # noqa: BLE001 - every kill point is tried: the report lists each one that fails
            failures.append(f"kill {n}: {str(exc).splitlines()[0] if isinstance(exc, AssertionError) else repr(exc)}")
    print("\n".join(log))
    assert failures == [], "\n".join(failures)
