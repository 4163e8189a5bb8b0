"""A pipeline's run folder: markers are untrusted control files and nothing derived from them leaves --workdir."""

from __future__ import annotations

import json
import os
from pathlib import Path

import pytest

from openral_data.errors import ConfigError, DatasetError
from openral_data.pipeline.schema import Step
from openral_data.pipeline.state import StepState, config_hash

STEP = Step.model_validate({"id": "all", "merge": {"inputs": ["rec"]}})


def _marker(workdir: Path, body: object) -> StepState:
    state = StepState(workdir, STEP)
    state.dir.mkdir(parents=True)
    state.marker.write_text(json.dumps(body))
    return state


def test_marker_output_names_stay_inside_the_workdir(tmp_path: Path) -> None:
    state = _marker(tmp_path / "run", {"config": StepState(tmp_path, STEP).hash, "outputs": {"../../x": "/x"}})
    with pytest.raises(DatasetError) as err:
        state.completed()
    assert err.value.code == "dataset.unsafe"


def test_marker_outputs_point_where_the_items_are(tmp_path: Path) -> None:
    state = _marker(tmp_path / "run", {"config": StepState(tmp_path, STEP).hash, "outputs": {"dataset": "/etc"}})
    done = state.completed()
    assert done is not None and done["outputs"] == {"dataset": str(tmp_path / "run" / "all" / "dataset")}


@pytest.mark.parametrize("body", [b"\xff\xfe", b"[1, 2]", b"{", b""])
def test_garbage_marker_is_one_line(tmp_path: Path, body: bytes) -> None:
    state = StepState(tmp_path, STEP)
    state.dir.mkdir()
    (state.dir / ".dataset.done").write_bytes(body)
    with pytest.raises(ConfigError) as err:
        state.item_done("dataset")
    assert "\n" not in str(err.value) and ".dataset.done" in str(err.value)


def test_symlinked_or_fifo_marker_is_refused(tmp_path: Path) -> None:
    outside = tmp_path / "outside.json"
    outside.write_text(json.dumps({"config": StepState(tmp_path, STEP).hash, "outputs": {}}))
    state = StepState(tmp_path / "run", STEP)
    state.dir.mkdir(parents=True)
    state.marker.symlink_to(outside)
    with pytest.raises(DatasetError):
        state.completed()
    state.marker.unlink()
    os.mkfifo(state.marker)
    with pytest.raises(DatasetError):
        state.completed()


def test_step_folder_symlinked_outside_is_refused(tmp_path: Path) -> None:
    elsewhere = tmp_path / "elsewhere"
    (elsewhere / "dataset").mkdir(parents=True)
    (elsewhere / "dataset" / "keep").write_text("keep")
    (tmp_path / "run").mkdir()
    (tmp_path / "run" / "all").symlink_to(elsewhere, target_is_directory=True)
    with pytest.raises(DatasetError):
        StepState(tmp_path / "run", STEP).start_item("dataset")
    assert (elsewhere / "dataset" / "keep").read_text() == "keep"


def test_a_step_keeps_its_hash_when_step_kinds_are_added() -> None:
    # the hashes the code before the train/filter/evaluate kinds gave these steps: a run made then resumes now
    rec = Step.model_validate({"id": "rec", "record": {"scenes": ["mock_pick"], "rskills": ["zero-mock"],
                                                       "seeds": {"count": 2}}})  # fmt: skip
    assert config_hash(rec) == "7e471e9dc323b323"
    assert config_hash(Step.model_validate({"id": "m", "merge": {"inputs": ["rec"]}})) == "46c3910d26b000ef"


def test_a_referenced_folder_hashes_by_what_configures_it(tmp_path: Path) -> None:
    # an rSkill folder: its code counts, what running it writes (__pycache__, hidden files) does not, and a
    # record step's hash with the pipeline's folder does not name where that folder is
    from openral_data.pipeline.portable import content_digest

    skill = tmp_path / "skill"
    (skill / "__pycache__").mkdir(parents=True)
    (skill / "rskill.yaml").write_text("id: s\n")
    (skill / "policy.py").write_text("ACTION = 0\n")
    before = content_digest(skill)
    (skill / "__pycache__" / "policy.cpython-312.pyc").write_bytes(b"\0")
    (skill / ".lock").write_text("")
    assert content_digest(skill) == before
    (skill / "policy.py").write_text("ACTION = 1\n")
    assert content_digest(skill) != before

    def rec(folder: Path) -> Step:
        skill = str(folder / "skill")
        return Step.model_validate({"id": "r", "record": {"scenes": ["mock_pick"], "rskills": [skill],
                                                          "seeds": {"count": 1}}})  # fmt: skip

    here = config_hash(rec(tmp_path), tmp_path)
    (tmp_path / "elsewhere").mkdir()
    skill.rename(tmp_path / "elsewhere" / "skill")
    assert config_hash(rec(tmp_path / "elsewhere"), tmp_path / "elsewhere") == here
    assert config_hash(rec(tmp_path)) != config_hash(rec(tmp_path / "elsewhere"))  # the legacy hash named the place
