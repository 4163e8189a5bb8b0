"""The `lerobot` policy adapter: a lerobot 0.6.1 ACT checkpoint made here, run on CPU, nothing downloaded."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest
import yaml

# CompatibilityError and ConfigError raises are matched by message on purpose: the file and field it names are the point
from openral_data.errors import CompatibilityError, ConfigError
from openral_data.formats.results import open_results
from openral_data.policies.base import ChunkingPolicy
from openral_data.replay import ReplayOptions, replay
from openral_data.replay.recorded import RecordedDataset
from openral_data.runtime import registry
from openral_data.types import Observation
from tests.support.checkpoint import make_act_checkpoint, make_diffusion_checkpoint
from tests.support.cli import run_cli
from tests.support.home import isolated_home
from tests.support.inproc import run_inproc
from tests.support.replay import record_push
from tests.support.scenes import write_yaml


def _act_rskill(home: Path, checkpoint: str, **changes: object) -> Path:
    """random-mock's contract (state 8, action 7, required_cameras [front]) run by the lerobot adapter."""
    data = yaml.safe_load((home / "rskills/random-mock/rskill.yaml").read_text())
    data.update(id="act-mock", policy="lerobot", policy_extras={"checkpoint": checkpoint}, **changes)
    return write_yaml(home / "rskills/act-mock/rskill.yaml", data)


def test_adapter_loads_a_local_checkpoint_and_acts_in_the_contract(
    mock: tuple[Path, Path], checkpoint: Path, tmp_path: Path
) -> None:
    dataset, home = mock
    manifest, _ = registry.resolve_rskill(str(_act_rskill(home, str(checkpoint))))
    policy = registry.POLICIES["lerobot"](manifest)
    assert isinstance(policy, ChunkingPolicy) and policy.n_action_steps == 4
    frame = next(RecordedDataset(dataset).frames(0))
    obs = Observation(images=frame.images, state=frame.state, task=frame.task)
    policy.reset(0)
    action = policy.step(obs, obs.task)
    assert action.dtype == np.float32 and action.shape == (7,) and np.isfinite(action).all()
    chunk = policy.predict_chunk(obs, obs.task)
    assert chunk.dtype == np.float32 and chunk.shape == (10, 7)  # chunk_size x action dim
    np.testing.assert_allclose(chunk[0], action, atol=1e-5)  # step() executes the chunk's first action

    summary = replay(ReplayOptions(dataset, mode="policy", rskill="act-mock", out=tmp_path / "res"))
    assert summary.summary["mode"] == "policy"
    recorded = RecordedDataset(dataset)
    for o in summary.episodes:
        assert o.action_abs is not None and o.action_abs.shape == recorded.episode(o.index).actions.shape
        assert np.isfinite(o.action_abs).all() and o.action_abs.max() > 0
    assert summary.summary["chunk"] == {"n_action_steps": 4}
    steps = pq.read_table(open_results(tmp_path / "res").steps_path)
    assert len(steps.column("action_abs_error")[0].as_py()) == 7


def test_relative_checkpoint_is_relative_to_the_manifest(mock: tuple[Path, Path], checkpoint: Path) -> None:
    _, home = mock
    path = _act_rskill(home, "weights")
    (path.parent / "weights").symlink_to(checkpoint, target_is_directory=True)
    manifest, _ = registry.resolve_rskill("act-mock")
    assert manifest.policy_extras["checkpoint"] == str((path.parent / "weights").resolve())
    (path.parent / "weights").unlink()
    with pytest.raises(ConfigError, match=r"policy_extras.checkpoint: .*weights is not a lerobot checkpoint"):
        registry.POLICIES["lerobot"](registry.resolve_rskill("act-mock")[0])


def test_record_passes_device_through_and_the_cli_wins_over_the_rskill(
    mock: tuple[Path, Path], checkpoint: Path, tmp_path: Path
) -> None:
    """An rSkill asking for a device this machine lacks is one line; `record --device cpu` runs it on the CPU (the
    CLI wins) and record.json notes the device used."""
    _, home = mock
    path = _act_rskill(home, str(checkpoint))
    data = yaml.safe_load(path.read_text())
    write_yaml(path, {**data, "policy_extras": {**data["policy_extras"], "device": "cuda:7"}})
    scene = home / "scenes/sim/mock_replay.yaml"
    args = ["record", "--scene", str(scene), "--rskill", "act-mock", "--n-episodes", "1", "--max-steps", "3"]
    refused = run_cli(*args, "--out", str(tmp_path / "no"))
    assert refused.returncode == 2 and not (tmp_path / "no").exists()
    assert refused.stderr.strip().startswith("error: rskill act-mock: policy_extras.device: cuda:7: torch sees ")
    out = tmp_path / "cpu"
    done = run_cli(*args, "--out", str(out), "--codec", "h264", "--device", "cpu")
    assert done.returncode == 0, done.stderr
    assert json.loads((out / ".openral/record.json").read_text())["options"]["device"] == "cpu"
    assert pq.read_metadata(sorted((out / "data").rglob("*.parquet"))[0]).num_rows == 3


@pytest.mark.parametrize(
    ("changes", "needle"),
    [
        ({"required_cameras": ["front", "wrist"]}, r"input_features: cameras \['front'\] but rskill act-mock"),
        (
            {"action_contract": {"dim": 6, "names": ["a", "b", "c", "d", "e", "f"]}},
            r"output_features.action: shape \[7\] does not match rskill act-mock action_contract.dim 6",
        ),
        (
            {"state_contract": {"dim": 3, "names": ["a", "b", "c"]}},
            r"input_features.observation.state: shape \[8\] does not match .* state_contract.dim 3",
        ),
    ],
)
def test_a_checkpoint_outside_the_contract_is_refused(
    mock: tuple[Path, Path], checkpoint: Path, changes: dict[str, object], needle: str
) -> None:
    manifest, _ = registry.resolve_rskill(str(_act_rskill(mock[1], str(checkpoint), **changes)))
    with pytest.raises(CompatibilityError, match=needle) as info:
        registry.POLICIES["lerobot"](manifest)
    assert "\n" not in str(info.value)


def test_record_policy_with_the_expert_taking_over_on_the_cli(
    mock: tuple[Path, Path], checkpoint: Path, tmp_path: Path
) -> None:
    """`record --policy CKPT --teleop expert` (#51): the DAgger round's path from the command line. The checkpoint
    drives, zero-mock takes over by the rule the options give (threshold 0: the policy always departs; after 2
    ticks; hands back after 3), the frames it drove are marked, the HAL was commanded its zeros there and the
    checkpoint's proposals elsewhere, and `openral.policy_action` holds the proposal of every frame."""
    from openral_data.columns import INTERVENTION, POLICY_ACTION
    from tests.support.hal import episode_infos, frames_table
    from tests.support.scenes import mock_scene

    scene = write_yaml(tmp_path / "long.yaml", mock_scene(scene_id="mock_long", success_after=50, n_episodes=1))
    rule = ("--takeover-threshold", "0", "--takeover-patience", "2", "--takeover-hold", "3")
    args = ["record", "--scene", str(scene), "--policy", str(checkpoint), "--teleop", "expert", "--expert", "zero-mock"]
    out = tmp_path / "round"
    done = run_inproc(*args, *rule, "--max-steps", "8", "--out", str(out), "--codec", "h264")
    assert done.returncode == 0, done.stderr
    table = frames_table(out)
    marks = table[INTERVENTION]
    assert marks == [False, False, True, True, True, False, False, True]
    proposals = np.asarray(table[POLICY_ACTION])
    assert proposals.shape == (8, 7) and np.all(np.abs(proposals).sum(axis=1) > 0)
    (info,) = episode_infos(out)
    assert info["operator"] == "policy:act+teleop:expert"
    names = [f"joint{i}" for i in range(1, 7)]  # the HAL's own log of what it was commanded (clamped ones)
    logged = [e for e in info["hal"]["intervention_log"] if e["name"] in names]
    assert {marks[e["frame"]] for e in logged} == {True, False}  # both drivers' commands were clamped at least once
    for entry in logged:
        want = 0.0 if marks[entry["frame"]] else proposals[entry["frame"], names.index(entry["name"])]
        assert entry["commanded"] == pytest.approx(want, abs=1e-6), entry
    refused = run_inproc(*args[:5], *rule[4:], "--out", str(tmp_path / "no"))
    assert (refused.returncode, refused.stderr.strip()) == (
        2,
        "error: --takeover-hold: only with --teleop expert (the scripted expert's settings)",
    )
    assert not (tmp_path / "no").exists()


def test_nothing_is_downloaded_even_when_the_config_names_imagenet_weights(
    mock: tuple[Path, Path], checkpoint: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import torchvision.models._api

    copy = tmp_path / "act"
    copy.mkdir()
    for f in checkpoint.iterdir():
        (copy / f.name).write_bytes(f.read_bytes())
    config = json.loads((copy / "config.json").read_text())
    config["pretrained_backbone_weights"] = "ResNet18_Weights.IMAGENET1K_V1"  # lerobot's ACT default
    (copy / "config.json").write_text(json.dumps(config))

    def no_network(*args: object, **kw: object) -> None:
        raise AssertionError(f"tried to download {args}")

    monkeypatch.setattr(torchvision.models._api, "load_state_dict_from_url", no_network)
    monkeypatch.setenv("TORCH_HOME", str(tmp_path / "torch_home"))
    manifest, _ = registry.resolve_rskill(str(_act_rskill(mock[1], str(copy))))
    policy = registry.POLICIES["lerobot"](manifest)
    frame = next(RecordedDataset(mock[0]).frames(1))
    assert policy.step(Observation(frame.images, frame.state, frame.task), frame.task).shape == (7,)
    assert not (tmp_path / "torch_home").exists()


def test_a_diffusion_checkpoint_runs_offline_or_is_refused_without_diffusers(
    mock: tuple[Path, Path], tmp_path: Path
) -> None:
    import importlib.util

    dataset, home = mock
    ckpt = tmp_path / "diffusion"
    if importlib.util.find_spec("diffusers") is None:
        # the default environment has no diffusers: the config alone decides, the weights are never read
        from lerobot.policies.diffusion.configuration_diffusion import DiffusionConfig

        ckpt.mkdir()
        DiffusionConfig(pretrained_backbone_weights=None)._save_pretrained(ckpt)
        (ckpt / "model.safetensors").write_bytes(b"")
        manifest, _ = registry.resolve_rskill(str(_act_rskill(home, str(ckpt))))
        with pytest.raises(ConfigError, match=r"diffusion policies need the diffusers package"):
            registry.POLICIES["lerobot"](manifest)
        return
    make_diffusion_checkpoint(dataset, ckpt, drop=("observation.images.wrist",))
    manifest, _ = registry.resolve_rskill(str(_act_rskill(home, str(ckpt))))
    policy = registry.POLICIES["lerobot"](manifest)
    assert not isinstance(policy, ChunkingPolicy)  # its chunks are queued inside step() with the obs history
    summary = replay(ReplayOptions(dataset, mode="policy", rskill="act-mock", episodes="0", out=tmp_path / "res"))
    outcome = summary.episodes[0]
    assert outcome.action_abs is not None and outcome.action_abs.shape == (outcome.steps, 7)
    assert np.isfinite(outcome.action_abs).all() and "chunk" not in summary.summary


@pytest.mark.slow
def test_act_trained_on_a_push_recording_runs_closed_loop_in_mujoco(tmp_path: Path) -> None:
    """Train ACT for a few real steps on a recorded tabletop_push dataset, then evaluate it offline and in the sim."""
    with isolated_home(tmp_path) as home:
        push = record_push(home, tmp_path / "push", n_episodes=2, seed=7).out
        ckpt = make_act_checkpoint(push, home / "rskills/lerobot-act-push/checkpoint", train_steps=2)
        offline = replay(ReplayOptions(push, mode="policy", rskill="lerobot-act-push", out=tmp_path / "offline"))
        assert offline.summary["mode"] == "policy"
        assert offline.summary["steps"] == sum(o.steps for o in offline.episodes) > 0
        assert len(offline.summary["action_mse"]) == 7 and offline.summary["chunk"] == {"n_action_steps": 4}
        loop = replay(
            ReplayOptions(
                push, mode="closed-loop", rskill="lerobot-act-push", max_steps=12, episodes="0", out=tmp_path / "loop"
            )
        )
        assert loop.episodes[0].steps <= 12 and loop.episodes[0].success_recorded is True
        assert loop.summary["mode"] == "closed-loop"
        paired = loop.summary["paired"]
        assert paired["both"] + paired["only_recorded"] + paired["only_policy"] + paired["neither"] == 1
        assert ckpt.is_dir()
