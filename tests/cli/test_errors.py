"""Bad input: one clear line on stderr naming the file/field, a non-zero exit, nothing written or lost."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest
import yaml

from tests.support.cli import run_cli
from tests.support.home import BUILTIN
from tests.support.scenes import mock_scene, write_yaml


def _fails(proc_args: list[str], pattern: str, env: dict[str, str] | None = None) -> str:
    proc = run_cli(*proc_args, env=env)
    assert proc.returncode == 2, (proc.returncode, proc.stdout, proc.stderr)
    lines = [ln for ln in proc.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1, proc.stderr  # one line, no traceback
    assert lines[0].startswith("error: "), lines
    assert re.search(pattern, lines[0]), lines[0]
    return lines[0]


def _rskill(project: Path, name: str, **changes: object) -> Path:
    data = yaml.safe_load((BUILTIN / "rskills/random-mock/rskill.yaml").read_text())
    data.update(changes, id=name)
    return write_yaml(project / "rskills" / name / "rskill.yaml", data)


def test_unknown_ids_list_the_valid_ones(project: Path, tmp_path: Path) -> None:
    out = str(tmp_path / "o")
    _fails(
        ["record", "--scene", "nope", "--out", out],
        r"unknown scene 'nope'; valid: aloha_.*, \.\.\. \(\d+ in all: openral-data list scenes\)$",
    )
    _fails(
        ["record", "--rskill", "nope", "--out", out],
        r"unknown rSkill 'nope'; valid: .*random-mock, .* in all: openral-data list rskills\)$",
    )
    _fails(["record", "--robot", "nope", "--out", out], r"unknown robot 'nope'; valid: .*mock_arm")
    _fails(["record", "--scene", str(tmp_path / "missing.yaml"), "--out", out], r"missing\.yaml: file not found")
    scene = mock_scene()
    scene["scene"]["type"] = "warp_drive"
    path = write_yaml(tmp_path / "s.yaml", scene)
    _fails(
        ["record", "--scene", str(path), "--out", out],
        r"s\.yaml: scene\.type: unknown scene type 'warp_drive'; valid: .*mock",
    )
    _rskill(project, "bad-policy", policy="telepathy")
    _fails(
        ["record", "--rskill", "bad-policy", "--out", out],
        r"bad-policy/rskill\.yaml: policy: unknown policy 'telepathy'; valid: .*random, .*zero",
    )
    assert not Path(out).exists()


def test_schema_errors_name_file_and_field(project: Path, tmp_path: Path) -> None:
    out = str(tmp_path / "o")
    scene = mock_scene()
    scene["scene"]["cameras"][0]["widht"] = 3
    path = write_yaml(tmp_path / "s.yaml", scene)
    _fails(["record", "--scene", str(path), "--out", out], r"s\.yaml: scene\.cameras\[0\]\.widht: unknown key")
    _fails(
        ["record", "--scene", str(BUILTIN / "scenes/deploy/mock_workcell.yaml"), "--out", out],
        "deploy scenes have no task",
    )
    vla = {**mock_scene(), "vla": {"checkpoint": "x"}}
    _fails(
        ["record", "--scene", str(write_yaml(tmp_path / "v.yaml", vla)), "--out", out],
        r"v\.yaml: vla: a scene must not name a policy",
    )
    bad_params = mock_scene(succes_after=3)
    _fails(
        ["record", "--scene", str(write_yaml(tmp_path / "p.yaml", bad_params)), "--out", out],
        r"p\.yaml: scene\.params: succes_after: unknown key",
    )
    assert not Path(out).exists()


def test_incompatibilities_fail_before_the_first_episode(project: Path, tmp_path: Path) -> None:
    out = tmp_path / "o"
    _rskill(project, "wrong-tags", embodiment_tags=["humanoid"])
    _fails(
        ["record", "--rskill", "wrong-tags", "--out", str(out)],
        r"wrong-tags/rskill\.yaml: embodiment_tags: \['humanoid'\] share nothing with robot 'mock_arm' tags "
        r"\['mock', 'single_arm'\] \(rSkills that fit: .*random-mock.*zero-mock",
    )
    _rskill(project, "needs-cam", required_cameras=["front", "thermal"])
    _fails(["record", "--rskill", "needs-cam", "--out", str(out)], r"required_cameras: \['thermal'\] not provided")
    dims = write_yaml(tmp_path / "dims.yaml", mock_scene(state_dim=5))
    _fails(
        ["record", "--scene", str(dims), "--out", str(out)],
        r"state_contract\.dim: 8 but scene .*dims\.yaml produces a state of 5",
    )
    odd = write_yaml(tmp_path / "odd.yaml", mock_scene(cameras=[("front", 63, 48)]))
    _fails(
        ["record", "--scene", str(odd), "--out", str(out)],
        r"odd\.yaml: scene\.cameras\.front: 63x48: video \(yuv420p\) needs even",
    )
    tiny = write_yaml(tmp_path / "tiny.yaml", mock_scene(cameras=[("front", 16, 16)]))
    _fails(
        ["record", "--scene", str(tiny), "--out", str(out)],
        r"tiny\.yaml: scene\.cameras\.front: 16x16: av1 video needs at least 32x32",
    )
    assert not out.exists()


@pytest.mark.parametrize(
    ("fault", "pattern"),
    [
        ("nan_state", r"episode 1 step 2: observation\.state: non-finite values at dims \[7\]"),
        ("float_image", r"episode 1 step 2: images\.front: expected uint8\[48, 64, 3\] \(HWC\), got float32"),
        ("wrong_image_shape", r"images\.front: expected uint8\[48, 64, 3\] \(HWC\), got uint8\[46, 64, 3\]"),
        ("extra_camera", r"undeclared \['undeclared_cam'\]"),
        ("missing_camera", r"missing \['front'\]"),
        ("state_dim", r"observation\.state: expected float32\[8\], got float32\[9\]"),
    ],
)
def test_contract_violation_mid_run_keeps_finished_episodes(
    tmp_path: Path, project: Path, fault: str, pattern: str
) -> None:
    scene = write_yaml(
        tmp_path / "f.yaml", mock_scene(success_after=4, fault={"kind": fault, "episode": 1, "at_step": 2})
    )
    out = tmp_path / "o"
    line = _fails(["record", "--scene", str(scene), "--out", str(out)], pattern)
    assert "1 finished episode(s) kept" in line
    info = json.loads((out / "meta/info.json").read_text())
    assert (info["total_episodes"], info["total_frames"]) == (1, 4)
    # nothing of the failed episode is left behind
    assert not list(out.rglob("*.tmp"))
    from tests.support.lerobot import verify_mock_dataset

    assert verify_mock_dataset(out, "pyav")["lengths"] == [4]


def test_violation_in_first_episode_leaves_nothing(tmp_path: Path, project: Path) -> None:
    scene = write_yaml(tmp_path / "f.yaml", mock_scene(fault={"kind": "nan_state", "episode": 0, "at_step": 0}))
    out = tmp_path / "o"
    _fails(["record", "--scene", str(scene), "--out", str(out)], "non-finite")
    assert not out.exists()
    out.mkdir()  # an empty folder the user made stays, and stays empty
    _fails(["record", "--scene", str(scene), "--out", str(out)], "non-finite")
    assert out.is_dir() and not any(out.iterdir())


def test_existing_output_is_never_overwritten(tmp_path: Path, project: Path) -> None:
    busy = tmp_path / "busy"
    busy.mkdir()
    (busy / "notes.txt").write_text("precious")
    _fails(["record", "--out", str(busy)], r"busy: --out exists, is not empty and is not a dataset")
    assert (busy / "notes.txt").read_text() == "precious" and len(list(busy.iterdir())) == 1
    ds = tmp_path / "ds"
    assert run_cli("record", "--n-episodes", "1", "--max-steps", "3", "--out", str(ds)).returncode == 0
    before = {p: p.read_bytes() for p in ds.rglob("*") if p.is_file()}
    _fails(["record", "--out", str(ds)], r"ds: --out already holds a dataset; refusing to overwrite it")
    assert {p: p.read_bytes() for p in ds.rglob("*") if p.is_file()} == before
    afile = tmp_path / "afile"
    afile.write_text("x")
    _fails(["record", "--out", str(afile)], "exists and is not a directory")


def test_bad_numbers_and_usage(tmp_path: Path, project: Path) -> None:
    _fails(["record", "--n-episodes", "0", "--out", str(tmp_path / "o")], "--n-episodes must be >= 1")
    _fails(["record", "--max-steps", "0", "--out", str(tmp_path / "o")], "--max-steps must be >= 1")
    proc = run_cli("record", "--codec", "mpeg2")
    assert proc.returncode == 2 and "Traceback" not in proc.stderr and "mpeg2" in proc.stderr
    _fails(["info", str(tmp_path)], "not a LeRobot v3 dataset")


def test_given_flags_are_what_the_parser_saw_not_a_value_compared_with_the_default(
    tmp_path: Path, project: Path
) -> None:
    """A flag repeated at its default value is still a flag the user gave (click's parameter source)."""
    out = str(tmp_path / "o")
    _fails(["record", "--out", out, "--view-port", "9876"], "--view, --view-port, --view-address: need --view")
    _fails(["record", "--out", out, "--mode", "sim", "--fps", "20"], "--mode, --fps: only with --hal ROBOT_ID")
    _fails(["record", "--out", out, "--image-format", "gif"], "--image-format: 'gif' is not one of jpeg, png, raw")
    assert not (tmp_path / "o").exists()


def test_list_commands(project: Path) -> None:
    scenes = run_cli("list", "scenes", "--all")
    assert scenes.returncode == 0 and "mock_pick" in scenes.stdout and "benchmark" in scenes.stdout
    rskills = run_cli("list", "rskills", "--all")
    assert rskills.returncode == 0 and "random-mock" in rskills.stdout
    # piped output is never cut to a terminal width: full ids, representations and tags
    assert "scripted-pick-place" in rskills.stdout and "delta_eef_gripper" in rskills.stdout
    robots = run_cli("list", "robots")
    assert robots.returncode == 0 and "mock_arm" in robots.stdout
    assert "franka_panda,single_arm,parallel_gripper" in robots.stdout


@pytest.mark.parametrize(
    ("args", "pattern"),
    [
        (["record", "--codec", "vp9"], r"^error: --vcodec: 'vp9' is not one of 'av1', 'h264', 'hevc', 'auto'$"),
        (["record", "--bogus"], r"No such option: --bogus"),
        (["recrd"], r"No such command 'recrd'\. Did you mean 'record'\?"),
        (["info"], r"Missing argument 'dataset'"),
        (["stats", "--format", "xml", "x"], r"^error: --format: 'xml' is not one of 'table'"),
        (["record", "--n-episodes", "many"], r"^error: --n-episodes: .*valid integer"),
    ],
)
def test_the_argument_parsers_own_errors_are_one_line(args: list[str], pattern: str) -> None:
    """typer/click's usage errors (unknown option or command, a value not among the choices, a missing
    argument) end like ours: one `error:` line naming the option, exit 2 — not a boxed usage message."""
    _fails(args, pattern)


def test_version_prints_the_package_metadata_version() -> None:
    from importlib.metadata import version

    done = run_cli("--version")
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == f"openral-data {version('openral-data')}"
