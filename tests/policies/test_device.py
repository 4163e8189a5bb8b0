"""`--device` / `policy_extras.device`: auto picks what torch sees (cpu on this machine), a device that is not here
is one line naming where it was asked for, and a non-neural policy records no device."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import torch

from openral_data.errors import ConfigError, UsageError
from openral_data.policies.device import resolve_device
from tests.support.cli import run_cli
from tests.support.scenes import mock_scene, write_yaml

NO_GPU = not torch.cuda.is_available()


@pytest.mark.skipif(not NO_GPU, reason="checks the refusal on a machine without CUDA")
def test_auto_is_cpu_here_and_cuda_is_refused_in_one_line() -> None:
    assert resolve_device("auto") == "cpu" and resolve_device("CPU") == "cpu"
    with pytest.raises(UsageError) as info:
        resolve_device("cuda")
    assert str(info.value) == "--device: cuda: torch sees no CUDA device here; use cpu or auto"
    with pytest.raises(UsageError, match=r"^--device: cuda:1: torch sees no CUDA device"):
        resolve_device("cuda:1")
    with pytest.raises(ConfigError, match=r"^rskill x: policy_extras.device: cuda: torch sees no CUDA"):
        resolve_device("cuda", "rskill x: policy_extras.device")
    with pytest.raises(UsageError) as bad:
        resolve_device("tpu")
    assert str(bad.value) == "--device: 'tpu' is not a device (cpu, cuda, cuda:N, mps, auto)"


@pytest.mark.skipif(not NO_GPU, reason="checks the refusal on a machine without CUDA")
def test_record_device_cuda_exits_2_before_writing_and_auto_records_without_a_network(
    project: Path, tmp_path: Path
) -> None:
    scene = write_yaml(project / "scene.yaml", mock_scene(success_after=2, n_episodes=1, max_steps=3))
    out = tmp_path / "ds"
    done = run_cli("record", "--scene", str(scene), "--out", str(out), "--device", "cuda")
    assert done.returncode == 2 and not out.exists()
    assert done.stderr.strip() == "error: --device: cuda: torch sees no CUDA device here; use cpu or auto"
    ok = run_cli("record", "--scene", str(scene), "--out", str(out), "--device", "auto", "--codec", "h264")
    assert ok.returncode == 0, ok.stderr
    options = json.loads((out / ".openral/record.json").read_text())["options"]
    assert options["device"] is None  # random-mock has no network: the device is ignored
