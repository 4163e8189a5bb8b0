"""An episode's instruction says the colours the episode shows.

A scene's `task.instruction` may name an object's colour as `{NAME.color}` (NAME: an object, `table` or `floor`);
each episode's instruction has it replaced by the colour name nearest that geom's rgba in the episode's model
(after domain randomization), e.g. `put the {cube.color} cube on the {goal.color} pad` -> `put the red cube on the
green pad`. An instruction that writes out the colour of something whose colour `randomize.colors` varies (the
word `blue` for a blue `goal` in `colors: [goal]`) would be false in most episodes: the scene is refused when it
loads, as is `{NAME.color}` for an unknown NAME or for a textured one (its colour is the texture's, not a word).
"""

from __future__ import annotations

import colorsys
import re
from collections.abc import Callable, Collection, Sequence

from openral_data.errors import ConfigError

COLOR_REF = re.compile(r"\{([A-Za-z][A-Za-z0-9_]*)\.colou?r\}")
# hue (degrees) upper bounds of the named colours of a saturated rgba
HUES = ((15, "red"), (45, "orange"), (70, "yellow"), (165, "green"), (200, "cyan"), (260, "blue"), (290, "purple"))
HUES_WRAP = ((340, "magenta"), (360, "red"))


def color_name(rgba: Sequence[float]) -> str:
    """The everyday name nearest an rgba (alpha ignored): black/white/gray by value and saturation, brown for a dark
    orange, else by hue."""
    h, s, v = colorsys.rgb_to_hsv(float(rgba[0]), float(rgba[1]), float(rgba[2]))
    if v < 0.2:
        return "black"
    if s < 0.2:
        return "white" if v > 0.8 else "gray"
    hue = h * 360
    if 15 <= hue < 45 and v < 0.6:
        return "brown"
    return next(name for bound, name in HUES + HUES_WRAP if hue < bound)


def check_instruction(
    instruction: str,
    rgba: Callable[[str], Sequence[float]],
    known: Collection[str],
    recolored: Collection[str],
    textured: Collection[str],
    source: str,
) -> None:
    """Refuse (ConfigError, `<source>: task.instruction: ...`) an instruction that can be false in an episode."""
    where = f"{source}: task.instruction"
    for name in COLOR_REF.findall(instruction):
        if name not in known:
            raise ConfigError(f"{where}: {{{name}.color}}: no object {name!r} (one of: {', '.join(sorted(known))})")
        if name in textured:
            raise ConfigError(f"{where}: {{{name}.color}}: {name!r} is textured per episode (randomize.textures)")
    words = set(re.findall(r"[a-z]+", COLOR_REF.sub("", instruction).lower()))
    for name in recolored:
        said = color_name(rgba(name))
        if said in words:
            raise ConfigError(
                f"{where}: says {said!r}, the colour of {name!r}, which randomize.colors varies per episode; "
                f"write {{{name}.color}} for the episode's own colour"
            )


def episode_instruction(instruction: str, rgba: Callable[[str], Sequence[float]]) -> str:
    """`instruction` with each `{NAME.color}` replaced by the colour name of NAME's current rgba."""
    return COLOR_REF.sub(lambda m: color_name(rgba(m.group(1))), instruction)
