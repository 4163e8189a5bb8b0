"""`record --policy PATH` and `replay --policy PATH`: a lerobot 0.6.1 checkpoint with no rSkill manifest, its
contract from its own config, checked against the scene or dataset before episode 0."""

from __future__ import annotations

import json
import shutil
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow.parquet as pq
import pytest

from tests.support.checkpoint import lerobot_actions, make_act_checkpoint, raw_images
from tests.support.inproc import run_inproc

SCENE = "scenes/sim/mock_replay.yaml"  # the mock: front 64x48 + wrist 32x32, state 8 and action 7 (random-mock)


def _copy(checkpoint: Path, dest: Path, **config: Any) -> Path:
    """A copy of `checkpoint` with config.json's top-level `config` entries replaced."""
    shutil.copytree(checkpoint, dest)
    doc = json.loads((dest / "config.json").read_text())
    (dest / "config.json").write_text(json.dumps({**doc, **config}))
    return dest


def _record(home: Path, policy: str, out: Path, *extra: str) -> Any:
    args = ["record", "--scene", str(home / SCENE), "--policy", policy, "--n-episodes", "2", "--max-steps", "5"]
    return run_inproc(*args, "--out", str(out), "--vcodec", "h264", *extra)


@pytest.mark.slow
def test_record_policy_path_acts_as_lerobots_own_policy(
    mock: tuple[Path, Path], checkpoint: Path, tmp_path: Path
) -> None:
    """A checkpoint folder drives the scene: each recorded action is what lerobot's own loaded policy computes on the
    recorded observation (state from the dataset, images the lossless MCAP copy), and each episode says who drove."""
    _, home = mock
    out = tmp_path / "rec"
    done = _record(home, str(checkpoint), out, "--format", "lerobot,mcap", "--image-format", "raw")
    assert done.returncode == 0, done.stderr
    table = pq.read_table(sorted((out / "data").rglob("*.parquet"))[0])
    episodes = table.column("episode_index").to_numpy()
    states = np.stack(table.column("observation.state").to_numpy(zero_copy_only=False)).astype(np.float32)
    actions = np.stack(table.column("action").to_numpy(zero_copy_only=False)).astype(np.float32)
    assert len(set(episodes.tolist())) == 2
    for e in (0, 1):
        rows = episodes == e
        images = raw_images(out / "mcap" / f"episode_{e:06d}", "front")
        want = lerobot_actions(checkpoint, states[rows], images, "pick up the mock cube")
        assert np.ptp(want, axis=0).max() > 1e-3  # the actions move: the frames matter
        np.testing.assert_allclose(actions[rows], want, rtol=1e-5, atol=1e-5)
    meta = pq.read_table(sorted((out / "meta/episodes").rglob("*.parquet"))[0])
    infos = [json.loads(v) for v in meta.column("openral.episode_info").to_pylist()]
    assert [i["operator"] for i in infos] == ["policy:act", "policy:act"]
    sql = run_inproc("stats", str(out), "--sql", "SELECT DISTINCT operator FROM episodes", "--format", "json")
    assert sql.returncode == 0 and "policy:act" in sql.stdout, sql.stderr
    record_json = json.loads((out / ".openral/record.json").read_text())["options"]
    assert record_json["policy"] == str(checkpoint.resolve()) and record_json["rskill"] is None

    again = run_inproc("replay", str(out), "--mode", "actions", "--out", str(tmp_path / "res"))
    assert again.returncode == 0, again.stderr  # the recording replays like any other


def test_resume_names_the_checkpoint_again(mock: tuple[Path, Path], checkpoint: Path, tmp_path: Path) -> None:
    """record.json never chooses a checkpoint: `--resume` of a `--policy` recording takes `--policy` again, the same."""
    _, home = mock
    out = tmp_path / "rec"
    assert _record(home, str(checkpoint), out, "--n-episodes", "1").returncode == 0
    _refused(run_inproc("record", "--resume", "--out", str(out)), "policy: recorded with the checkpoint ")
    other = _copy(checkpoint, tmp_path / "other")
    _refused(run_inproc("record", "--resume", "--out", str(out), "--policy", str(other)), "--policy ")
    done = run_inproc("record", "--resume", "--out", str(out), "--policy", str(checkpoint), "--n-episodes", "2")
    assert done.returncode == 0, done.stderr
    assert pq.read_metadata(sorted((out / "meta/episodes").rglob("*.parquet"))[0]).num_rows == 2


def test_a_training_runs_folder_and_a_cached_hub_repo_resolve(
    mock: tuple[Path, Path], checkpoint: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """`outputs/train/run` (its checkpoints/last/pretrained_model) and a repo id found in the local HF cache."""
    from huggingface_hub import constants

    from openral_data.policies.checkpoint import open_checkpoint

    run = tmp_path / "run"
    shutil.copytree(checkpoint, run / "checkpoints/000002/pretrained_model")
    (run / "checkpoints/last").symlink_to("000002", target_is_directory=True)
    found = open_checkpoint(str(run))
    assert found.name == "run@000002" and found.contract.state_dim == 8 and found.contract.action_dim == 7
    assert found.contract.cameras == {"front": (3, 48, 64)}

    cache = tmp_path / "hub"
    repo = cache / "models--someone--act-mock"
    snapshot = repo / "snapshots" / ("a" * 40)
    snapshot.mkdir(parents=True)
    (repo / "blobs").mkdir()
    for f in checkpoint.iterdir():  # huggingface_hub's layout: snapshot files link to ../../blobs/<hash>
        (repo / "blobs" / f.name).write_bytes(f.read_bytes())
        (snapshot / f.name).symlink_to(f"../../blobs/{f.name}")
    (repo / "refs").mkdir()
    (repo / "refs/main").write_text("a" * 40)
    monkeypatch.setattr(constants, "HF_HUB_CACHE", str(cache))
    monkeypatch.setenv("HF_HUB_OFFLINE", "1")
    _, home = mock
    done = _record(home, "someone/act-mock", tmp_path / "rec", "--n-episodes", "1")
    assert done.returncode == 0, done.stderr
    meta = pq.read_table(sorted((tmp_path / "rec/meta/episodes").rglob("*.parquet"))[0])
    assert json.loads(meta.column("openral.episode_info")[0].as_py())["operator"] == "policy:someone/act-mock"

    missing = _record(home, "someone/not-here", tmp_path / "no")
    assert missing.returncode == 2 and not (tmp_path / "no").exists()
    assert missing.stderr.startswith("error: --policy someone/not-here: not a folder, and not in the local Hugging")
    assert "hf download someone/not-here" in missing.stderr and missing.stderr.count("\n") == 1


def test_replay_policy_and_closed_loop_take_a_checkpoint(
    mock: tuple[Path, Path], checkpoint: Path, tmp_path: Path
) -> None:
    dataset, _ = mock
    offline = run_inproc("replay", str(dataset), "--mode", "policy", "--policy", str(checkpoint), "--json")
    assert offline.returncode == 0, offline.stderr
    summary = json.loads(offline.stdout)
    assert summary["rskill"] == f"policy:{checkpoint}" and summary["steps_compared"] > 0
    assert summary["chunk_n_action_steps"] == 4
    args = ["replay", str(dataset), "--mode", "closed-loop", "--policy", str(checkpoint), "--episodes", "0"]
    loop = run_inproc(*args, "--out", str(tmp_path / "loop"))
    assert loop.returncode == 0, loop.stderr


@pytest.mark.slow
def test_replay_policy_on_a_dataset_lerobot_wrote(tmp_path: Path) -> None:
    """Foreign data: a checkpoint made on a lerobot-written dataset is judged on it (no openral metadata)."""
    from tests.support.lerobot_written import write_lerobot_dataset

    write_lerobot_dataset(tmp_path / "ds", with_success=False)
    ckpt = make_act_checkpoint(tmp_path / "ds", tmp_path / "ckpt")
    done = run_inproc("replay", str(tmp_path / "ds"), "--mode", "policy", "--policy", str(ckpt), "--json")
    assert done.returncode == 0, done.stderr
    assert json.loads(done.stdout)["steps_compared"] == 19


def _refused(run: Any, needle: str) -> None:
    assert run.returncode == 2, run.stderr
    assert run.stderr.startswith("error: ") and run.stderr.count("\n") == 1, run.stderr
    assert needle in run.stderr, run.stderr


@pytest.mark.parametrize(
    ("config", "needle"),
    [
        (
            {"input_features": {"observation.state": {"type": "STATE", "shape": [3]}}},
            "config.json: input_features.observation.state: shape [3] but scene ",
        ),
        (
            {"output_features": {"action": {"type": "ACTION", "shape": [6]}}},
            "config.json: output_features.action: shape [6] but scene ",
        ),
        (
            {
                "input_features": {
                    "observation.state": {"type": "STATE", "shape": [8]},
                    "observation.images.front": {"type": "VISUAL", "shape": [3, 40, 64]},
                }
            },
            "config.json: input_features.observation.images.front.shape: 40x64 (HxW) but scene ",
        ),
        (
            {
                "input_features": {
                    "observation.state": {"type": "STATE", "shape": [8]},
                    "observation.images.top": {"type": "VISUAL", "shape": [3, 48, 64]},
                }
            },
            "config.json: input_features.observation.images.top: camera 'top' but scene ",
        ),
        (  # a state-only policy on object poses: the mock scene records none
            {
                "input_features": {
                    "observation.state": {"type": "STATE", "shape": [8]},
                    "observation.environment_state": {"type": "ENV", "shape": [14]},
                }
            },
            "config.json: input_features.observation.environment_state: shape [14] but scene ",
        ),
        ({"type": "evil"}, "config.json: type: 'evil' policies are not supported (act, diffusion)"),
        ({"fps": 7}, "config.json: fps: 7 but scene "),
    ],
)
def test_a_checkpoint_that_does_not_fit_the_scene_is_one_line(
    mock: tuple[Path, Path], checkpoint: Path, tmp_path: Path, config: dict[str, Any], needle: str
) -> None:
    _, home = mock
    bad = _copy(checkpoint, tmp_path / "bad", **config)
    _refused(_record(home, str(bad), tmp_path / "out"), needle)
    assert not (tmp_path / "out").exists()


def test_broken_or_escaping_checkpoints_are_one_line(mock: tuple[Path, Path], checkpoint: Path, tmp_path: Path) -> None:
    _, home = mock
    garbled = _copy(checkpoint, tmp_path / "garbled")
    (garbled / "config.json").write_text("{not json")
    _refused(_record(home, str(garbled), tmp_path / "o1"), "config.json: invalid JSON")
    no_weights = _copy(checkpoint, tmp_path / "no_weights")
    (no_weights / "model.safetensors").unlink()
    _refused(_record(home, str(no_weights), tmp_path / "o2"), "model.safetensors: missing")
    empty = tmp_path / "empty"
    empty.mkdir()
    _refused(_record(home, str(empty), tmp_path / "o3"), "config.json: missing; not a lerobot checkpoint folder")
    escaping = _copy(checkpoint, tmp_path / "escaping")
    (escaping / "config.json").unlink()
    (escaping / "config.json").symlink_to(checkpoint / "config.json")
    _refused(_record(home, str(escaping), tmp_path / "o4"), "leads outside")
    both = _record(home, str(checkpoint), tmp_path / "o5", "--rskill", "random-mock")
    _refused(both, "--policy, --rskill: give one")
    assert not any((tmp_path / f"o{i}").exists() for i in range(1, 6))


def test_replay_refuses_a_policy_where_it_takes_none_or_does_not_fit(
    mock: tuple[Path, Path], checkpoint: Path, tmp_path: Path
) -> None:
    dataset, _ = mock
    _refused(run_inproc("replay", str(dataset), "--policy", str(checkpoint)), "--policy: --mode actions replays")
    both = run_inproc("replay", str(dataset), "--mode", "policy", "--policy", str(checkpoint), "--rskill", "x")
    _refused(both, "--policy, --rskill: give one")
    small = _copy(checkpoint, tmp_path / "small", output_features={"action": {"type": "ACTION", "shape": [2]}})
    _refused(
        run_inproc("replay", str(dataset), "--mode", "policy", "--policy", str(small)),
        f"config.json: output_features.action: shape [2] but dataset {dataset} takes actions of 7",
    )


def _state_step(folder: Path, name: str) -> tuple[dict[str, Any], dict[str, Any]]:
    """`folder/name`'s JSON and its first step that names a state file (the normaliser's)."""
    doc = json.loads((folder / name).read_text())
    return doc, next(s for s in doc["steps"] if "state_file" in s)


@pytest.mark.parametrize(
    ("case", "needle"),
    [
        ("processor_symlink", "policy_preprocessor.json: path 'policy_preprocessor.json' leads outside "),
        ("absolute_state_file", "policy_postprocessor.json: steps[0].state_file: path '/"),
        ("dotdot_state_file", "policy_postprocessor.json: steps[0].state_file: path '../"),
        ("state_file_symlink", "policy_postprocessor.json: steps[0].state_file: path 'policy_postprocessor_step_"),
        ("missing_state_file", "policy_postprocessor.json: steps[0].state_file: 'gone.safetensors' is missing"),
        ("state_file_not_a_name", "policy_postprocessor.json: steps[0].state_file: 7 is not a file name"),
    ],
)
def test_processor_and_state_files_must_stay_inside_the_checkpoint(
    mock: tuple[Path, Path], checkpoint: Path, tmp_path: Path, case: str, needle: str
) -> None:
    """lerobot opens the processors' JSON and `base_path / state_file`: a symlink out, an absolute path or `..`
    would read anywhere; each is one line, exit 2, nothing written."""
    _, home = mock
    outside = tmp_path / "outside"
    shutil.copytree(checkpoint, outside)  # a valid checkpoint elsewhere: what a link out would read
    bad = _copy(checkpoint, tmp_path / "bad")
    doc, step = _state_step(bad, "policy_postprocessor.json")
    if case == "processor_symlink":
        (bad / "policy_preprocessor.json").unlink()
        (bad / "policy_preprocessor.json").symlink_to(outside / "policy_preprocessor.json")
    elif case == "state_file_symlink":
        (bad / step["state_file"]).unlink()
        (bad / step["state_file"]).symlink_to(outside / step["state_file"])
    else:
        step["state_file"] = {
            "absolute_state_file": str(outside / step["state_file"]),
            "dotdot_state_file": f"../outside/{step['state_file']}",
            "missing_state_file": "gone.safetensors",
            "state_file_not_a_name": 7,
        }[case]
        (bad / "policy_postprocessor.json").write_text(json.dumps(doc))
    _refused(_record(home, str(bad), tmp_path / "out"), needle)
    assert not (tmp_path / "out").exists()
