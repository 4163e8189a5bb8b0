"""A checkpoint's files are untrusted: the rSkill route (`policy: lerobot`) keeps them inside the checkpoint
folder as `record --policy` does, and weights that are broken or do not fit the config are one line."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest
import yaml

from openral_data.errors import DatasetError
from openral_data.runtime import registry
from tests.support.inproc import run_inproc
from tests.support.scenes import write_yaml


def _rskill(home: Path, checkpoint: Path) -> Path:
    """random-mock's contract run by the lerobot adapter from `checkpoint`."""
    data = yaml.safe_load((home / "rskills/random-mock/rskill.yaml").read_text())
    data.update(id="act-files", policy="lerobot", policy_extras={"checkpoint": str(checkpoint)})
    return write_yaml(home / "rskills/act-files/rskill.yaml", data)


@pytest.mark.parametrize("name", ["config.json", "model.safetensors", "policy_preprocessor.json"])
def test_the_rskill_route_keeps_the_checkpoint_files_inside(
    mock: tuple[Path, Path], checkpoint: Path, tmp_path: Path, name: str
) -> None:
    bad = tmp_path / "bad"
    shutil.copytree(checkpoint, bad)
    (bad / name).unlink()
    (bad / name).symlink_to(checkpoint / name)
    manifest, _ = registry.resolve_rskill(str(_rskill(mock[1], bad)))
    with pytest.raises(DatasetError, match=f"{name}: path '{name}' leads outside ") as info:
        registry.POLICIES["lerobot"](manifest)
    assert info.value.code == "dataset.unsafe" and "\n" not in str(info.value)


def _record(home: Path, policy: Path, out: Path) -> tuple[int, str]:
    scene = str(home / "scenes/sim/mock_replay.yaml")
    done = run_inproc("record", "--scene", scene, "--policy", str(policy), "--max-steps", "3", "--out", str(out))
    return done.returncode, done.stderr


def test_truncated_weights_are_one_line(mock: tuple[Path, Path], checkpoint: Path, tmp_path: Path) -> None:
    bad = tmp_path / "cut"
    shutil.copytree(checkpoint, bad)
    weights = bad / "model.safetensors"
    weights.write_bytes(weights.read_bytes()[:100])
    code, err = _record(mock[1], bad, tmp_path / "out")
    assert code == 2 and err.startswith(f"error: {weights}: weights: not readable safetensors "), err
    assert err.count("\n") == 1 and not (tmp_path / "out").exists()


def test_weights_that_do_not_fit_the_config_are_one_line(
    mock: tuple[Path, Path], checkpoint: Path, tmp_path: Path
) -> None:
    bad = tmp_path / "narrow"
    shutil.copytree(checkpoint, bad)
    config = json.loads((bad / "config.json").read_text())
    (bad / "config.json").write_text(json.dumps({**config, "dim_model": 32}))  # the weights are 64 wide
    code, err = _record(mock[1], bad, tmp_path / "out")
    assert code == 2 and err.startswith(f"error: {bad / 'model.safetensors'}: weights: do not fit config.json: "), err
    assert (
        "size mismatch for " in err
        and "more)" in err
        and len(err) < 800
        and err.count("\n") == 1
        and not (tmp_path / "out").exists()
    )
