"""#29 class 1: nothing read from a dataset or a pipeline file chooses code.

`record --resume` takes the scene and rSkill from the dataset's `.openral/record.json` only through the manifest
search path (a scene or rSkill file elsewhere must be named again); a pipeline's `scenes:`/`rskills:` are ids or paths
inside its own folder; a lerobot checkpoint's processor steps must be lerobot's registered ones. Each attack
below ran its payload (or loaded what it named) before the fix.
"""

from __future__ import annotations

import hashlib
import json
import shutil
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
import yaml

from openral_data.formats.lerobot_v3 import layout
from openral_data.schemas.scene import SimScene, load_recordable_scene
from tests.support.checkpoint import make_act_checkpoint
from tests.support.home import isolated_home
from tests.support.inproc import run_inproc
from tests.support.interrupt import snapshot
from tests.support.replay import record_mock
from tests.support.scenes import mock_scene, write_yaml

POPEN = "subprocess.Popen"


def _one_error(run: tuple[int, str], start: str, needle: str) -> None:
    code, err = run
    lines = err.strip().splitlines()
    assert code == 2 and len(lines) == 1, err
    assert lines[0].startswith(f"error: {start}") and needle in lines[0], lines[0]


def _absent(canary: Path) -> bool:
    """The payload (a `touch` started in the background) had time to run and did not."""
    time.sleep(0.5)
    return not canary.exists()


def _set_option(out: Path, name: str, value: object) -> None:
    path = out / layout.RECORD_PATH
    doc = json.loads(path.read_text())
    doc["options"][name] = value
    path.write_text(json.dumps(doc))


def _resume(out: Path, *args: str) -> tuple[int, str]:
    done = run_inproc("record", "--resume", "--out", str(out), "--n-episodes", "4", *args)
    return done.returncode, done.stderr


# --- a planted lerobot rSkill whose checkpoint would run a command -------------------------------------------


@pytest.fixture(scope="module")
def planted(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[Path, Path, Path]]:
    """(project home, a mock dataset holding `evil/rskill.yaml` + `evil/ckpt/` whose preprocessor runs
    `touch <canary>`, the canary path)."""
    base = tmp_path_factory.mktemp("planted")
    canary = base / "canary"
    with isolated_home(base) as home:
        out = record_mock(home, base / "ds").out
        ckpt = make_act_checkpoint(out, out / "evil/ckpt", drop=("observation.images.wrist",))
        pre = ckpt / "policy_preprocessor.json"
        doc = json.loads(pre.read_text())
        doc["steps"].append({"class": POPEN, "config": {"args": ["touch", str(canary)]}})
        pre.write_text(json.dumps(doc))
        rskill = yaml.safe_load((home / "rskills/random-mock/rskill.yaml").read_text())
        rskill.update(id="evil", policy="lerobot", policy_extras={"checkpoint": "ckpt"})
        write_yaml(out / "evil/rskill.yaml", rskill)
        yield home, out, canary


@pytest.mark.slow
def test_resume_never_loads_an_rskill_planted_in_the_dataset(planted: tuple[Path, Path, Path], tmp_path: Path) -> None:
    _, source, canary = planted
    out = shutil.copytree(source, tmp_path / "ds")
    _set_option(out, "rskill", str(out / "evil"))
    before = snapshot(out)
    refused = _resume(out)
    assert _absent(canary)  # (before the fix: the policy loaded beside the scene and its preprocessor ran it)
    _one_error(refused, f"{out / layout.RECORD_PATH}: rskill: ", "not on the manifest search path")
    assert snapshot(out) == before


@pytest.mark.slow
def test_a_processor_step_outside_lerobots_registry_is_refused(
    planted: tuple[Path, Path, Path], tmp_path: Path
) -> None:
    """The user names the rSkill (a checkpoint is code they chose); its unregistered step is still refused."""
    home, source, canary = planted
    rskill = home / "rskills/evil/rskill.yaml"
    data = yaml.safe_load((source / "evil/rskill.yaml").read_text())
    data["policy_extras"]["checkpoint"] = str(source / "evil/ckpt")
    write_yaml(rskill, data)
    try:
        done = run_inproc("record", "--scene", "mock_replay", "--rskill", "evil", "--out", str(tmp_path / "o"))
    finally:
        shutil.rmtree(rskill.parent)
    pre = source / "evil/ckpt/policy_preprocessor.json"
    steps = len(json.loads(pre.read_text())["steps"])
    assert _absent(canary)
    _one_error((done.returncode, done.stderr), f"{pre}: steps[{steps - 1}]: ", f"'{POPEN}' is not a registered lerobot")
    assert not (tmp_path / "o").exists()


# --- record.json naming manifests off the search path --------------------------------------------------------


@pytest.fixture
def recorded(tmp_path: Path, project: Path) -> Path:
    """A one-episode mock recording of a scene file outside the search path (`--scene PATH`): `tmp_path/ds`,
    recorded from `tmp_path/scene.yaml` (`_named`)."""
    scene = write_yaml(tmp_path / "scene.yaml", mock_scene(success_after=3, max_steps=4, n_episodes=1))
    out = tmp_path / "ds"
    done = run_inproc("record", "--scene", str(scene), "--out", str(out), "--codec", "h264")
    assert done.returncode == 0, done.stderr
    return out


def _named(recorded: Path) -> tuple[str, str]:
    """`--scene` naming the scene file `recorded` was made from again, as a resume of it must."""
    return "--scene", str(recorded.parent / "scene.yaml")


@pytest.mark.parametrize("where", ["home", "absolute", "relative"])
def test_resume_refuses_an_rskill_path_from_record_json(
    recorded: Path, project: Path, tmp_path: Path, where: str
) -> None:
    """A valid rSkill file, but one the dataset chose: never loaded (`~` and relative paths not even expanded)."""
    outside = write_yaml(
        tmp_path / "elsewhere/rskill.yaml", yaml.safe_load((project / "rskills/random-mock/rskill.yaml").read_text())
    )
    value = {"home": "~/rskills/random-mock", "absolute": str(outside), "relative": "elsewhere"}[where]
    _set_option(recorded, "rskill", value)
    before = snapshot(recorded)
    _one_error(_resume(recorded, *_named(recorded)), f"{recorded / layout.RECORD_PATH}: rskill: ", "--rskill")
    assert snapshot(recorded) == before


@pytest.mark.parametrize("where", ["outside", "inside"])
def test_resume_refuses_a_scene_file_from_record_json(
    recorded: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, where: str
) -> None:
    """A scene YAML the dataset points at, with the true sha256 of its bytes (record.json vouches for itself, so
    it could name any file whose bytes an attacker knows): refused before it is read. Before the fix the one
    outside the dataset was loaded and recorded into it."""
    other = mock_scene(success_after=2, max_steps=3, n_episodes=1)
    scene = write_yaml((tmp_path if where == "outside" else recorded) / "other.yaml", other)
    _set_option(recorded, "scene", str(scene))
    _set_option(recorded, "scene_sha256", hashlib.sha256(scene.read_bytes()).hexdigest())
    loaded: list[Path] = []

    def spy(path: Path) -> SimScene:
        loaded.append(path)
        return load_recordable_scene(path)

    monkeypatch.setattr("openral_data.record.sim.load_recordable_scene", spy)
    before = snapshot(recorded)
    record_json = recorded / layout.RECORD_PATH
    _one_error(_resume(recorded), f"{record_json}: scene: {str(scene)!r} is not on the manifest search path", "--scene")
    assert loaded == [] and snapshot(recorded) == before


def test_resume_with_the_scene_named_again(recorded: Path, tmp_path: Path) -> None:
    """The user names the scene file again: used, if its bytes still have the sha256 the recording stored (a
    dataset continues with the scene it was recorded with)."""
    record_json = recorded / layout.RECORD_PATH
    scene = tmp_path / "scene.yaml"
    original = scene.read_text()
    scene.write_text(original.replace("success_after", "success_after ", 1))  # same meaning, other bytes
    before = snapshot(recorded)
    _one_error(_resume(recorded, *_named(recorded)), f"{record_json}: scene: ", "changed since the recording")
    scene.write_text(original)
    assert snapshot(recorded) == before
    other = tmp_path / "other.yaml"
    other.write_text(original)
    _one_error(_resume(recorded, "--scene", str(other)), f"{record_json}: scene: ", "name the file it was recorded")
    done = run_inproc("record", "--resume", "--out", str(recorded), "--n-episodes", "2", *_named(recorded))
    assert done.returncode == 0, done.stderr


def test_recordings_from_before_the_digest(recorded: Path, tmp_path: Path) -> None:
    """Without `scene_sha256` (older recordings) a scene on the search path still resumes (record.json holds the
    resolved path of its file), a file elsewhere is named again."""
    path = recorded / layout.RECORD_PATH
    doc = json.loads(path.read_text())
    del doc["options"]["scene_sha256"]
    path.write_text(json.dumps(doc))
    _one_error(_resume(recorded), f"{path}: scene: ", "not on the manifest search path")
    assert _resume(recorded, *_named(recorded))[0] == 0
    out = tmp_path / "ids"
    args = ["--n-episodes", "1", "--max-steps", "3", "--codec", "h264"]
    assert run_inproc("record", "--scene", "mock_pick", "--out", str(out), *args).returncode == 0
    _set_option(out, "scene_sha256", None)
    done = run_inproc("record", "--resume", "--out", str(out), "--n-episodes", "2")
    assert done.returncode == 0, done.stderr


# --- pipeline files ------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("field", "ref", "needle"),
    [
        ("rskills", "../outside", "leads outside"),
        ("rskills", "~/rskills/random-mock", "is neither an rSkill id"),
        ("scenes", "/etc/scene.yaml", "is absolute"),
    ],
)
def test_pipeline_manifests_stay_in_its_folder(
    tmp_path: Path, project: Path, field: str, ref: str, needle: str
) -> None:
    outside = tmp_path / "outside"
    outside.mkdir()
    (outside / "rskill.yaml").write_text((project / "rskills/random-mock/rskill.yaml").read_text())
    record = {"scenes": ["mock_pick"], "rskills": ["random-mock"], "seeds": {"count": 1}, field: [ref]}
    spec = write_yaml(tmp_path / "p/pipeline.yaml", {"name": "t", "steps": [{"id": "rec", "record": record}]})
    work = tmp_path / "work"
    done = run_inproc("pipeline", "run", str(spec), "--workdir", str(work))
    _one_error((done.returncode, done.stderr), f"{spec}: steps[0].record.{field}[0]: ", needle)
    assert not work.exists()


def test_pipeline_manifest_paths_are_relative_to_its_folder(tmp_path: Path, project: Path) -> None:
    from openral_data.pipeline.schema import load_pipeline

    folder = tmp_path / "p"
    write_yaml(folder / "scenes/mine.yaml", mock_scene(success_after=3, max_steps=4, n_episodes=1))
    record = {"scenes": ["scenes/mine.yaml", "mock_pick"], "rskills": ["random-mock"], "seeds": {"count": 1}}
    spec = write_yaml(folder / "pipeline.yaml", {"name": "t", "steps": [{"id": "rec", "record": record}]})
    step = load_pipeline(spec).steps[0].record
    assert step is not None and step.scenes == [str(folder / "scenes/mine.yaml"), "mock_pick"]


# --- numbers -------------------------------------------------------------------------------------------------


def test_max_steps_is_bounded(tmp_path: Path, project: Path, recorded: Path) -> None:
    """`10**12` steps per episode (or `1e30` in record.json) is a typo, not a limit: refused before recording."""
    data = mock_scene(n_episodes=1)
    data["task"]["max_steps"] = 10**12
    scene = write_yaml(tmp_path / "big.yaml", data)
    done = run_inproc("record", "--scene", str(scene), "--out", str(tmp_path / "o"))
    _one_error((done.returncode, done.stderr), f"{scene}: task.max_steps", "10000000")
    record = {"scenes": ["mock_pick"], "rskills": ["random-mock"], "seeds": {"count": 1}, "max_steps": 10**12}
    spec = write_yaml(tmp_path / "p.yaml", {"name": "t", "steps": [{"id": "rec", "record": record}]})
    done = run_inproc("pipeline", "run", str(spec), "--workdir", str(tmp_path / "w"))
    _one_error((done.returncode, done.stderr), f"{spec}: steps[0].record.max_steps", "10000000")
    _set_option(recorded, "max_steps", 1e30)
    before = snapshot(recorded)
    _one_error(
        _resume(recorded, *_named(recorded)), f"{recorded / layout.RECORD_PATH}: max_steps: 1e+30", "whole number"
    )
    assert snapshot(recorded) == before and not (tmp_path / "o").exists() and not (tmp_path / "w").exists()
