"""`generate --annotations FILE`: the segments of source episodes given by hand instead of found from gripper
events. A YAML (or JSON) file, untrusted input (bounded, validated):

    episodes:
      0: [{end: 52, object: cube}, {end: 140, object: goal}]   # frames 0..51 relative to the cube, 52..139 the goal
      3: [{end: 60, object: cube}, {end: 150, object: goal}]

An episode not listed is cut from its gripper events; the last segment of a listed one runs to the episode's end.
"""

from __future__ import annotations

from pathlib import Path

from pydantic import Field, model_validator

from openral_data.errors import ConfigError
from openral_data.formats.jsonfile import read_text_file
from openral_data.schemas.base import StrictModel, parse_yaml, validate

MAX_BYTES = 4 << 20


class Cut(StrictModel):
    end: int = Field(gt=0)
    object: str = Field(min_length=1, max_length=200)


class Annotations(StrictModel):
    episodes: dict[int, list[Cut]] = Field(default_factory=dict)

    @model_validator(mode="after")
    def _check(self) -> Annotations:
        for e, cuts in self.episodes.items():
            ends = [c.end for c in cuts]
            if not cuts or ends != sorted(set(ends)):
                raise ValueError(f"episodes.{e}: ends must be given, strictly increasing")
        return self

    def cuts(self, episode: int, length: int) -> list[tuple[int, str]] | None:
        given = self.episodes.get(episode)
        if given is None:
            return None
        if given[-1].end > length:
            raise ConfigError(
                f"annotations: episodes.{episode}: end {given[-1].end} is past the episode's {length} frames"
            )
        out = [(c.end, c.object) for c in given]
        if out[-1][0] < length:
            out[-1] = (length, out[-1][1])
        return out


def read_annotations(path: Path) -> Annotations:
    raw = read_text_file(path, MAX_BYTES, "an annotations file")
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ConfigError(f"{path}: not UTF-8 text (byte {exc.start})") from None
    data = parse_yaml(text, str(path))  # bounded numbers, no duplicate keys
    return validate(Annotations, data, str(path))
