"""Silent wrong answers (#29, class 9) and what user-given SQL may reach (class 10): each case used to exit 0 with
a wrong or empty answer; now it is one `error:` line and exit 2, a doctor finding, or the right answer."""

from __future__ import annotations

import errno
import json
import shutil
from pathlib import Path

import pytest

from openral_data.doctor.command import DoctorReport
from tests.support.bags import write_plain_mcap
from tests.support.faults import Faults, inject
from tests.support.home import isolated_home
from tests.support.inproc import Run, run_inproc
from tests.support.malformed import snapshot

VIDEO = "videos/observation.images.front/chunk-000/file-000.mp4"


@pytest.fixture(scope="module")
def recorded(tmp_path_factory: pytest.TempPathFactory) -> Path:
    base = tmp_path_factory.mktemp("silent")
    with isolated_home(base):
        run = run_inproc(
            "record", "--n-episodes", "2", "--max-steps", "3", "--codec", "h264", "--out", str(base / "ds")
        )
    assert run.returncode == 0, run.stderr
    return base / "ds"


@pytest.fixture
def ds(tmp_path: Path, recorded: Path) -> Path:
    return Path(shutil.copytree(recorded, tmp_path / "ds"))


def one_line(run: Run, names: str) -> str:
    """Exit 2 with exactly one `error:` line that mentions `names`."""
    lines = [ln for ln in run.stderr.splitlines() if ln.strip()]
    assert run.returncode == 2 and len(lines) == 1, (run.returncode, run.stdout, run.stderr)
    assert lines[0].startswith("error: ") and names in lines[0], lines[0]
    return lines[0]


def doctor_codes(root: Path) -> tuple[int, list[str]]:
    run = run_inproc("doctor", str(root), "--json")
    assert "Traceback" not in run.stderr, run.stderr
    return run.returncode, [f["code"] for f in json.loads(run.stdout)["findings"]]


# -- doctor --repair ---------------------------------------------------------------------------------------------
def _too_few_frames(root: Path) -> None:
    info = json.loads((root / "meta/info.json").read_text())
    info["total_frames"] -= 1
    (root / "meta/info.json").write_text(json.dumps(info))


def test_repair_on_a_failing_disk_is_one_line(tmp_path: Path, recorded: Path) -> None:
    """EIO on the last write call of a repair (after its rename: the fix itself landed) used to print a `refused`
    line and exit 0; it is `write.disk`, exit 2, for every call that can fail."""
    clean = Path(shutil.copytree(recorded, tmp_path / "clean"))
    _too_few_frames(clean)
    counted = Faults(armed=True)
    with inject(counted):
        assert run_inproc("doctor", str(clean), "--repair").returncode == 0
    assert counted.calls, "the repair wrote nothing"
    for n in (1, len(counted.calls)):
        root = Path(shutil.copytree(recorded, tmp_path / f"fail{n}"))
        _too_few_frames(root)
        with inject(Faults(fail_at=n, errno=errno.EIO, persist=False, armed=True)):
            run = run_inproc("doctor", str(root), "--repair")
        one_line(run, "input/output error while repairing")


def test_a_refused_repair_is_not_exit_0() -> None:
    report = DoctorReport(Path("ds"), [], repair=True, refused=["stopped in totals: cannot read the dataset"])
    assert report.exit_code == 1 and report.to_json()["exit_code"] == 1


# -- doctor: files it used to ignore ------------------------------------------------------------------------------
def test_doctor_reports_a_traversing_rehash_list(ds: Path) -> None:
    """`record --resume` refuses it (recovery would hash outside files); doctor called the dataset healthy."""
    (ds / ".openral/rehash.json").write_text(json.dumps(["../outside/data/chunk-000/file-000.parquet"]))
    code, codes = doctor_codes(ds)
    assert code == 1 and "rehash.unsafe" in codes, codes
    (ds / ".openral/rehash.json").write_text(json.dumps({"not": "a list"}))
    code, codes = doctor_codes(ds)
    assert code == 1 and "rehash.invalid" in codes, codes


@pytest.mark.parametrize(
    ("text", "exit_code"),
    [
        ("{", 1),
        ("[]", 1),
        ('"x"', 1),
        (json.dumps({"schema_metadata": "scene", "config": {}}), 0),  # readers take it as unknown: a warning
        (json.dumps({"config": [1]}), 0),
    ],
)
def test_doctor_reports_a_garbage_openral_json(ds: Path, text: str, exit_code: int) -> None:
    (ds / "meta/openral.json").write_text(text)
    assert doctor_codes(ds) == (exit_code, ["openral.invalid"])


def test_doctor_keeps_a_good_dataset_healthy(ds: Path) -> None:
    assert doctor_codes(ds) == (0, [])


# -- stats: paths with glob characters, and what --sql may reach ---------------------------------------------------
def test_stats_reads_a_folder_named_like_a_glob(tmp_path: Path, recorded: Path) -> None:
    """`ds[1]` is that folder, not its sibling `ds1` (neither for our argument expansion nor for DuckDB's)."""
    named = Path(shutil.copytree(recorded, tmp_path / "ds[1]"))
    sibling = Path(shutil.copytree(recorded, tmp_path / "ds1"))
    (sibling / "meta/episodes").rename(sibling / "meta/old-episodes")
    shutil.copytree(named / "meta/episodes", sibling / "meta/episodes")
    run = run_inproc("stats", str(named), "--sql", "SELECT dataset, count(*) AS n FROM frames GROUP BY ALL")
    assert run.returncode == 0, run.stderr
    run = run_inproc("stats", str(named), "--format", "csv", "--sql", "SELECT DISTINCT dataset FROM episodes")
    assert run.returncode == 0 and run.stdout.split() == ["dataset", "ds[1]"], run.stdout
    shutil.rmtree(sibling / "data")  # what DuckDB would glob instead of ds[1]'s own data files
    run = run_inproc("stats", str(named), "--format", "csv", "--sql", "SELECT count(*) AS n FROM frames")
    assert run.returncode == 0 and run.stdout.split() == ["n", "6"], (run.stdout, run.stderr)


@pytest.mark.parametrize(
    ("sql", "names"),
    [
        ("COPY (SELECT 1) TO '{out}'", "only SELECT queries"),
        ("SELECT 1; COPY (SELECT 1) TO '{out}'", "only SELECT queries"),
        ("EXPLAIN ANALYZE COPY (SELECT 1) TO '{out}'", "only SELECT queries"),
        ("ATTACH '{out}' AS x", "only SELECT queries"),
        ("COPY (SELECT 1 AS a) TO '{data}' (FORMAT parquet, USE_TMP_FILE false)", "only SELECT queries"),
        ("SELECT * FROM read_csv('{canary}')", "disabled by configuration"),
        ("SELECT * FROM glob('{root}/*')", "disabled by configuration"),
    ],
)
def test_stats_sql_is_read_only(tmp_path: Path, ds: Path, sql: str, names: str) -> None:
    canary = tmp_path / "canary.csv"
    canary.write_text("a\n1\n")
    before = snapshot(tmp_path)
    data = ds / "data/chunk-000/file-000.parquet"
    query = sql.format(out=tmp_path / "outside.csv", data=data, canary=canary, root=tmp_path)
    one_line(run_inproc("stats", str(ds), "--sql", query), names)
    assert snapshot(tmp_path) == before


def test_stats_sql_still_answers_a_select(ds: Path) -> None:
    sql = "SELECT t.task, count(*) AS n FROM frames f JOIN tasks t USING (dataset, task_index) GROUP BY ALL"
    run = run_inproc("stats", str(ds), "--format", "csv", "--sql", sql)
    assert run.returncode == 0 and run.stdout.split("\n")[1] == "pick up the mock cube,6", run.stdout


def test_where_reads_only_the_dataset(tmp_path: Path, ds: Path) -> None:
    canary = tmp_path / "canary.csv"
    canary.write_text("a\n1\n")
    where = f"(SELECT count(*) FROM read_csv('{canary}')) > 0"
    run = run_inproc("episodes", "filter", str(ds), "--where", where, "--out", str(tmp_path / "f"))
    one_line(run, "disabled by configuration")
    assert not (tmp_path / "f").exists()


# -- view ----------------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("keep", [0.0, 0.5, None])
def test_view_refuses_an_mcap_rerun_cannot_read(tmp_path: Path, keep: float | None) -> None:
    """Garbage, or cut short (no summary): rerun only logs its refusal, and an empty recording was "saved"."""
    bag = write_plain_mcap(tmp_path / "log.mcap", duration_ms=400)
    data = bag.read_bytes()
    bag.write_bytes(b"\x00garbage" * 500 if keep is None else data[: int(len(data) * keep)])
    one_line(run_inproc("view", str(bag), "--save", str(tmp_path / "v.rrd")), "log.mcap: cannot read MCAP")
    assert not (tmp_path / "v.rrd").exists()


def test_view_refuses_a_truncated_mp4(tmp_path: Path, ds: Path) -> None:
    video = ds / VIDEO
    video.write_bytes(video.read_bytes()[: video.stat().st_size // 2])
    for episode in ("0", "1"):
        run = run_inproc("view", str(ds), "--episode", episode, "--save", str(tmp_path / "v.rrd"))
        one_line(run, "observation.images.front")
        assert not (tmp_path / "v.rrd").exists()


# -- info and tasks list count what is there ----------------------------------------------------------------------
def _set_info(root: Path, **changes: int) -> None:
    info = json.loads((root / "meta/info.json").read_text())
    info.update(changes)
    (root / "meta/info.json").write_text(json.dumps(info))


def test_tasks_list_does_not_hide_tasks(ds: Path) -> None:
    """`total_tasks: 0` used to make `tasks list` print nothing, and `info` say the dataset has no task."""
    _set_info(ds, total_tasks=0)
    for cmd in ("info", "tasks list"):
        one_line(run_inproc(*cmd.split(), str(ds)), "info.json: total_tasks: 0, but meta/tasks.parquet holds 1")


def test_rows_past_the_totals_are_an_unfinished_commit(ds: Path) -> None:
    """A killed writer's last episode row may be on disk before info.json counts it: info reads the committed
    episodes (as before), it does not refuse."""
    _set_info(ds, total_episodes=1, total_frames=3)
    run = run_inproc("info", str(ds), "--json")
    assert run.returncode == 0, run.stderr
    assert (json.loads(run.stdout)["episodes"], json.loads(run.stdout)["frames"]) == (1, 3)
