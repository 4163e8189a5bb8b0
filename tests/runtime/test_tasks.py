"""`record --task` / `--instruction` on the mock scene (the suites' own --task tests live beside their scenes):
the instruction is every frame's task as lerobot 0.6.1 reads it back and what the policy is given, it is a resume
setting, and a scene type without tasks refuses --task in one line."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from openral_data.errors import UsageError
from openral_data.record.options import RecordOptions
from openral_data.record.sim import record
from openral_data.runtime import registry
from openral_data.runtime.tasks import choose_task, tasks_of
from tests.support.cli import run_cli
from tests.support.policies import listening
from tests.support.scenes import mock_scene, write_yaml

INSTRUCTION = "wave at the camera, then pick up the cube"


def _lerobot_tasks(root: Path) -> list[str]:
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    ds = LeRobotDataset("local/check", root=root, video_backend="pyav")
    return [str(ds[i]["task"]) for i in range(len(ds))]


def _options(out: Path) -> dict[str, object]:
    options: dict[str, object] = json.loads((out / ".openral/record.json").read_text())["options"]
    return options


def test_instruction_is_every_frames_task_in_lerobot_and_a_resume_setting(project: Path, tmp_path: Path) -> None:
    scene = write_yaml(project / "scene.yaml", mock_scene(success_after=[3, 4], n_episodes=2, max_steps=6))
    out = tmp_path / "ds"
    base = ["record", "--scene", str(scene), "--out", str(out), "--codec", "h264"]
    first = run_cli(*base, "--n-episodes", "1", "--instruction", INSTRUCTION)
    assert first.returncode == 0, first.stderr
    assert _lerobot_tasks(out) == [INSTRUCTION] * 3  # not the YAML's "pick up the mock cube"
    options = _options(out)
    assert options["instruction"] == INSTRUCTION and options["task"] is None and options["device"] is None

    other = run_cli(*base, "--resume", "--instruction", "something else")
    assert other.returncode == 2
    line = other.stderr.strip()
    assert "\n" not in line and line.startswith(f"error: {out / '.openral/record.json'}: instruction: ")
    assert f"recorded with {INSTRUCTION}; --instruction something else differs" in line
    assert _lerobot_tasks(out) == [INSTRUCTION] * 3  # nothing changed

    resumed = run_cli(*base, "--resume", "--n-episodes", "2")  # the recorded instruction goes on
    assert resumed.returncode == 0, resumed.stderr
    assert _lerobot_tasks(out) == [INSTRUCTION] * (3 + 4)


def test_the_policy_is_given_the_instruction(project: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    seen: list[str] = []

    monkeypatch.setitem(registry.POLICIES, "zero", listening(seen))
    scene = write_yaml(project / "scene.yaml", mock_scene(success_after=3, n_episodes=1, max_steps=6))
    record(RecordOptions(scene=str(scene), rskill="zero-mock", out=tmp_path / "a", codec="h264"))
    assert seen == ["pick up the mock cube"] * 3  # the YAML's, without --instruction
    seen.clear()
    record(RecordOptions(scene=str(scene), rskill="zero-mock", out=tmp_path / "b", codec="h264", instruction="go"))
    assert seen == ["go"] * 3


def test_a_scene_without_tasks_refuses_task_and_nothing_is_written(project: Path, tmp_path: Path) -> None:
    scene = write_yaml(project / "scene.yaml", mock_scene(n_episodes=1, max_steps=4))
    out = tmp_path / "ds"
    done = run_cli("record", "--scene", str(scene), "--out", str(out), "--task", "anything")
    assert done.returncode == 2
    assert done.stderr.strip() == (
        f"error: {scene}: scene.type: 'mock' scenes have no tasks to choose (--task); "
        "scene types with tasks: gym_aloha, libero, maniskill, metaworld, robosuite"
    )
    assert not out.exists()
    empty = run_cli("record", "--scene", str(scene), "--out", str(out), "--instruction", " ")
    assert empty.returncode == 2 and empty.stderr.strip() == "error: --instruction: must not be empty"
    listed = run_cli("list", "tasks", str(scene))
    assert listed.returncode == 2 and "scene.type: 'mock' scenes have no tasks" in listed.stderr


def test_suite_tasks_are_declared_without_building_a_scene(project: Path) -> None:
    """robosuite and gym-aloha declare their tasks statically: listing and choosing builds nothing."""
    scene, tasks = tasks_of("robosuite_lift")
    assert [t.id for t in tasks][:3] == ["Lift", "Stack", "PickPlaceCan"]
    chosen, ident = choose_task(scene, "Stack", "robosuite_lift.yaml")
    assert ident == "Stack" and chosen.scene.params["env"] == "Stack"
    assert chosen.task.instruction == "stack the red cube on the green cube"
    assert chosen.scene.params["controller"] == scene.scene.params["controller"]  # the rest of the params stay
    with pytest.raises(UsageError) as info:
        choose_task(scene, "Lfit", "robosuite_lift.yaml")
    assert str(info.value) == (
        "--task: unknown task 'Lfit' of scene robosuite_lift; did you mean 'Lift'? "
        "(8 in all: openral-data list tasks robosuite_lift)"
    )
    aloha, found = tasks_of("aloha_insertion")
    assert [t.id for t in found] == ["insertion", "transfer_cube"]
    assert choose_task(aloha, "transfer_cube", "x")[0].scene.params == {"task": "transfer_cube"}
    assert registry.scene_types_with_tasks() == ["gym_aloha", "libero", "maniskill", "metaworld", "robosuite"]
    maniskill, offered = tasks_of("maniskill_pick_cube")  # a static table: ManiSkill is not installed here
    assert [t.id for t in offered][:3] == ["PickCube-v1", "PushCube-v1", "StackCube-v1"] and len(offered) == 12
    stack = choose_task(maniskill, "StackCube-v1", "x")[0]
    assert stack.scene.params == {"env_id": "StackCube-v1"}
    assert stack.task.instruction == "stack the red cube on the green cube"
