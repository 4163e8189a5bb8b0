"""Policy checkpoints of `record --policy` that choose code or size memory (#49): a config whose `chunk_size`
or a feature shape is absurd, a preprocessor with a registered step that loads a model or a tokenizer. Each is
one line naming the file and field, before lerobot builds or loads anything of it."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

from tests.malformed.corpus.cases import case
from tests.support.malformed import Workspace
from tests.support.scenes import mock_scene, write_yaml

FEATURES = {
    "input_features": {
        "observation.state": {"type": "STATE", "shape": [8]},
        "observation.images.front": {"type": "VISUAL", "shape": [3, 48, 64]},
    },
    "output_features": {"action": {"type": "ACTION", "shape": [7]}},
}


def _checkpoint(w: Workspace, config: dict[str, Any], steps: list[dict[str, Any]] | None = None) -> Path:
    """A hand-written ACT checkpoint for the mock scene (empty weights: refused before they are read)."""
    folder = w.path("ckpt/config.json").parent
    (folder / "config.json").write_text(json.dumps({"type": "act", **FEATURES, **config}))
    (folder / "model.safetensors").write_bytes(b"")
    if steps is not None:
        doc = {"name": "policy_preprocessor", "steps": steps}
        (folder / "policy_preprocessor.json").write_text(json.dumps(doc))
    return folder


def _ckpt_case(id: str, make: Callable[[Workspace], Path], names: str) -> None:
    def build(w: Workspace) -> list[str]:
        ckpt = make(w)
        scene = write_yaml(w.path("scene/mock_replay.yaml"), mock_scene(scene_id="mock_replay", n_episodes=1))
        return ["record", "--scene", str(scene), "--policy", str(ckpt), "--max-steps", "3", "--out", str(w.root / "o")]

    case(id, build, names, ("o",))


_ckpt_case("checkpoint-chunk-size-1e9", lambda w: _checkpoint(w, {"chunk_size": 10**9}), r"config\.json: chunk_size")
_ckpt_case("checkpoint-n-obs-steps-text", lambda w: _checkpoint(w, {"n_obs_steps": "9"}), r"config\.json: n_obs_steps")
_ckpt_case(
    "checkpoint-huge-image-feature",
    lambda w: _checkpoint(
        w, {"input_features": {**FEATURES["input_features"], "observation.images.front": {"shape": [3, 10**6, 64]}}}
    ),
    r"config\.json: input_features\.observation\.images\.front\.shape",
)
_ckpt_case(
    "checkpoint-reward-classifier-step",
    lambda w: _checkpoint(
        w, {}, [{"registry_name": "reward_classifier_processor", "config": {"pretrained_path": str(w.root)}}]
    ),
    r"policy_preprocessor\.json: steps\[0\]: 'reward_classifier_processor'",
)
