"""Scene files for tests: YAML writing and the mock scene's manifest."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import yaml


def write_yaml(path: Path, data: Any) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path


def mock_scene(
    *,
    scene_id: str = "mock_test",
    cameras: list[tuple[str, int, int]] | None = None,
    success_after: int | list[int] = 5,
    max_steps: int = 50,
    n_episodes: int = 3,
    fps: int = 20,
    **params: Any,
) -> dict[str, Any]:
    cams = cameras if cameras is not None else [("front", 64, 48), ("wrist", 32, 32)]
    return {
        "tier": "sim",
        "scene": {
            "id": scene_id,
            "type": "mock",
            "robot": "mock_arm",
            "fps": fps,
            "cameras": [{"name": n, "width": w, "height": h} for n, w, h in cams],
            "params": {"success_after": success_after, **params},
        },
        "task": {"scene_id": scene_id, "instruction": "pick up the mock cube", "max_steps": max_steps},
        "seed": 0,
        "n_episodes": n_episodes,
    }
