"""The terminal keyboard's teleop keys, in one place and without numpy: the keyboard teleop (keyboard.py) reads
them, and the command line shows them (`record --help`, the prompt before episode 0)."""

from __future__ import annotations

AXES = {"i": (0, 1), "k": (0, -1), "j": (1, 1), "l": (1, -1), "u": (2, 1), "m": (2, -1), "[": (3, 1), "]": (3, -1)}
ARROWS = {"A": "i", "B": "k", "D": "j", "C": "l"}  # ESC [ A/B/C/D: up, down, right, left
GRIPPER_KEY = "g"
HALT_KEY = "h"
TAKEOVER_KEY = "t"  # with a policy driving (interventions): the person takes over and hands back
HELP = (
    "teleop keys: i/k (up/down arrows) +x/-x · j/l (left/right arrows) +y/-y · u/m +z/-z · [/] +yaw/-yaw · "
    "g gripper open/close · h halt"
)
