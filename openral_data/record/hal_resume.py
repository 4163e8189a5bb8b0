"""`record --hal ROBOT --resume --out OUT`: continue a HAL recording with the settings it started with.

A fresh `record --hal` keeps its settings in ``OUT/.openral/record.json`` (`options`: the robot under `hal`, the
mode, the scene behind the HAL, fps, step limit, episode time, seed, codec and encoder settings, formats, MCAP
image format and compression, the episodes wanted; `schema`: fps, cameras, contracts, outcomes), as a scene
recording does (record/output.py). `--resume` takes the settings not given again from there; one given again
must match, except `--n-episodes` (the total wanted); `--hal` must name the recorded robot. Who drives (the
rSkill, `--policy`, `--teleop`) is named again, as for a fresh run: its contract, the cameras and the fps are
checked against the recorded schema before the robot is connected, and the dataset's features against the
writer's (`restore.check_same_format`). Under the writer lock `recovery.recover` then finishes a commit a kill
cut short and quarantines what the killed session left of the episode in flight (its partial mp4s and the
frames it had spilled to disk: that episode's rows were only in the killed process's memory, so it can never be
committed); the run continues the dataset's episode numbering and seeds (seed + episode index).

A DAgger round (`--teleop expert`) also keeps its expert and takeover rule (`options.expert`: the expert's rSkill,
`threshold`, `patience`, `hold`): a resume that drives with `--teleop expert` again takes them back unless given,
and one given again must match, so every episode of the round is corrected by the same rule and its intervention
rate means one thing.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

from openral_data.errors import ConfigError, DatasetError, UsageError
from openral_data.formats.codec import parse_codec
from openral_data.formats.lerobot_v3.encoder import VideoSettings
from openral_data.formats.mcap.messages import parse_image_format
from openral_data.formats.mcap.writer import parse_compression
from openral_data.producers.hal.teleop.declare import TakeoverRule
from openral_data.record import recorded
from openral_data.record.output import HAL_KEY, RANGES, read_settings, recorded_video, settings_path, video_json
from openral_data.runtime.sinks import parse_formats

# HalRecordOptions fields a resume keeps, with the CLI option that sets each (`robot` is record.json's `hal`)
HAL_KEPT = {
    "robot": "--hal",
    "mode": "--mode",
    "scene": "--scene",
    "fps": "--fps",
    "max_steps": "--max-steps",
    "episode_time_s": "--episode-time-s",
    "seed": "--seed",
    "codec": "--codec",
    "formats": "--format",
    "image_format": "--image-format",
    "mcap_compression": "--mcap-compression",
}
MAX_FPS = 1000
# the takeover rule's fields a DAgger round keeps (`options.expert`), with the CLI option that sets each
EXPERT_KEPT = {"threshold": "--takeover-threshold", "patience": "--takeover-patience", "hold": "--takeover-hold"}
MAX_TICKS = 10**6  # a patience or hold beyond this many ticks is not a rule


def hal_settings(values: Mapping[str, Any], n_episodes: int, video: VideoSettings) -> dict[str, Any]:
    """record.json's `options` of a fresh HAL recording: `values` holds each `HAL_KEPT` field's value."""
    doc = {("hal" if name == "robot" else name): values[name] for name in HAL_KEPT}
    return {**doc, "formats": list(values["formats"]), "n_episodes": n_episodes, "video": video_json(video)}


def continue_hal(
    out: Path,
    values: Mapping[str, Any],
    explicit: frozenset[str],
    video: VideoSettings,
    takeover: tuple[str | None, TakeoverRule] | None = None,
) -> dict[str, Any]:
    """The recorded settings of the HAL recording in `out`, as HalRecordOptions changes: each `HAL_KEPT` field
    (its `values` given again must match), `n_episodes` unless given, and `video`; with `takeover` (the expert
    and rule given to a resume with `--teleop expert`) also the round's own (`continue_expert`). Read under the
    writer lock."""
    path = settings_path(out)
    saved = read_settings(out).get("options")
    if not isinstance(saved, dict):
        raise DatasetError(f"{path}: options: missing or not a mapping", code="dataset.invalid")
    if HAL_KEY not in saved:
        raise ConfigError(f"{path}: {HAL_KEY}: recorded from a scene, not --hal; continue it with record --resume")
    changes: dict[str, Any] = {}
    for name, flag in HAL_KEPT.items():
        stored = _checked(name, saved.get(HAL_KEY if name == "robot" else name), path)
        given = values[name]
        same = recorded.same("scene", given, stored) if name == "scene" and given and stored else given == stored
        if (name in explicit or name == "robot") and not same:
            shown = ",".join(given) if name == "formats" else given
            hint = f"--hal {stored}" if name == "robot" else "leave the option out to continue with the recorded one"
            raise ConfigError(
                f"{path}: {HAL_KEY if name == 'robot' else name}: the dataset was recorded with "
                f"{_show(stored)}; {flag} {shown} differs ({hint})"
            )
        changes[name] = stored
    if "n_episodes" not in explicit:
        changes["n_episodes"] = _checked("n_episodes", saved.get("n_episodes"), path)
    changes["video"] = recorded_video(video, saved.get("video"), explicit, path, changes["codec"])
    if takeover is not None:
        changes.update(continue_expert(saved.get("expert"), path, *takeover, explicit))
    return changes


def expert_settings(expert: str | None, rule: TakeoverRule) -> dict[str, Any]:
    """record.json's `options.expert` of a `--teleop expert` recording: the expert's rSkill and its rule."""
    return {"rskill": expert, **{name: getattr(rule, name) for name in EXPERT_KEPT}}


def continue_expert(
    saved: Any, path: Path, expert: str | None, rule: TakeoverRule, explicit: frozenset[str]
) -> dict[str, Any]:
    """The expert and takeover rule a `--teleop expert` recording was made with (`saved`: its record.json's
    `options.expert`, at `path`), as HalRecordOptions changes (`expert`, `takeover_rule`); a value given again
    (`explicit`: the option's name) must match. Nothing when the recording kept none (another driver, or recorded
    before they were kept)."""
    if saved is None:
        return {}
    if not isinstance(saved, dict):
        raise DatasetError(f"{path}: expert: {saved!r}: not a mapping", code="dataset.invalid")
    values = {name: _rule_value(name, saved.get(name), path) for name in EXPERT_KEPT}
    for name, flag in EXPERT_KEPT.items():
        if f"takeover_{name}" in explicit and getattr(rule, name) != values[name]:
            raise ConfigError(
                f"{path}: expert.{name}: the round was recorded with {values[name]:g}; {flag} "
                f"{getattr(rule, name):g} differs (leave the option out to continue with the recorded one)"
            )
    stored = saved.get("rskill")
    if "expert" in explicit:
        if expert is None or stored is None or not recorded.same("rskill", expert, stored):
            raise ConfigError(
                f"{path}: expert.rskill: the round was recorded with {stored or 'the scene rSkill'}; --expert "
                f"{expert} differs (leave the option out to continue with the recorded one)"
            )
    else:
        expert = None if stored is None else recorded.trusted("rskill", stored, path, flag="--expert")
    kept = TakeoverRule(float(values["threshold"]), int(values["patience"]), int(values["hold"]))
    return {"expert": expert, "takeover_rule": kept}


def _rule_value(name: str, value: Any, path: Path) -> float | int:
    """A recorded takeover rule field, checked as the CLI checks its option (record.json is dataset content)."""
    if name == "threshold" and type(value) in (int, float) and 0 <= value < MAX_TICKS:
        return float(value)
    if name != "threshold" and type(value) is int and 1 <= value <= MAX_TICKS:
        return int(value)
    what = "not a number >= 0" if name == "threshold" else f"not a whole number in 1..{MAX_TICKS}"
    raise DatasetError(f"{path}: expert.{name}: {value!r}: {what}", code="dataset.invalid")


def _checked(name: str, value: Any, path: Path) -> Any:
    """A recorded setting, checked as the CLI checks the option (record.json is dataset content)."""
    try:
        if name in _PARSERS:
            if not isinstance(value, str):
                raise TypeError("not a string")
            return _PARSERS[name](value)
        if name == "formats":
            if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
                raise TypeError("not a list of names")
            return parse_formats(",".join(value))
        if name == "scene":
            return None if value is None else recorded.trusted("scene", value, path)
        if name == "episode_time_s":
            if value is not None and (type(value) not in (int, float) or not 0 < value < 10**6):
                raise TypeError("not a positive number of seconds")
            return value
        if name == "robot":
            if not isinstance(value, str):
                raise TypeError("not a robot id")
            return value
        low, high = RANGES.get(name, (1, MAX_FPS))
        if (value is None and name == "max_steps") or (type(value) is int and low <= value <= high):
            return value
        raise TypeError(f"not a whole number in {low}..{high}")
    except (TypeError, UsageError) as exc:
        field = HAL_KEY if name == "robot" else name
        raise DatasetError(f"{path}: {field}: {value!r}: {exc}", code="dataset.invalid") from None


def _mode(value: str) -> str:
    if value not in ("sim", "real"):
        raise UsageError("not sim or real")
    return value


_PARSERS: dict[str, Callable[[str], Any]] = {
    "mode": _mode,
    "codec": parse_codec,
    "image_format": parse_image_format,
    "mcap_compression": parse_compression,
}


def _show(value: Any) -> str:
    return ",".join(value) if isinstance(value, tuple) else str(value)
