"""A scene's `scene.params`, validated against the backend's own strict model."""

from __future__ import annotations

from pydantic import BaseModel

from openral_data.schemas.base import validate
from openral_data.schemas.scene import SimScene


def parse_params[M: BaseModel](model: type[M], scene: SimScene, source: str) -> M:
    """The scene's params as `model`; ConfigError naming `<source>: scene.params.<field>` otherwise."""
    return validate(model, scene.scene.params, f"{source}: scene.params")
