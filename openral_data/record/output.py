"""`record --resume`: continue a recording with the settings it started with, after any crash.

A recording keeps its settings in ``OUT/.openral/record.json`` (scene, rSkill, robot, seed, step limit,
codec, formats, image format, MCAP chunk compression, task, instruction, the requested episode count and the
dataset schema; the device a neural policy ran on is noted too, but a resume may run on another). `--resume` takes them
from there (the scene and rSkill only as `record/recorded.py` allows: record.json is dataset content, it never
chooses code); an option given again must match, except `--n-episodes` (the total wanted). Under the dataset's
writer lock it then recovers each sink (`recovery.recover` for LeRobot, the staging folder for MCAP) and, if a
kill fell between the sinks' commits of one episode, sets aside the sink that got one episode further (the
MCAP sink commits first, and a bag is one folder to move).
"""

from __future__ import annotations

import contextlib
import json
import logging
import shutil
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from openral_data.errors import ConfigError, DatasetBusy, DatasetError, UsageError
from openral_data.formats import atomic
from openral_data.formats.jsonfile import parse_json
from openral_data.formats.lerobot_v3 import layout
from openral_data.formats.lerobot_v3.encoder import VideoSettings, parse_codec
from openral_data.formats.lerobot_v3.links import refuse_outside_links
from openral_data.formats.lerobot_v3.loadable import check_loadable
from openral_data.formats.lerobot_v3.lock import DatasetLock, holder
from openral_data.formats.lerobot_v3.reader import read_info
from openral_data.formats.lerobot_v3.recovery import Quarantine, recover
from openral_data.formats.mcap.writer import MCAP_SUBDIR, PARTIAL, bags_dir, finished_bags
from openral_data.formats.staging import clean_orphans, unwritable
from openral_data.record import recorded
from openral_data.record.options import RecordOptions
from openral_data.runtime.outdir import check_out
from openral_data.schemas.scene import MAX_SEED, MAX_STEPS
from openral_data.types import DatasetSchema

# RecordOptions fields kept for a resume, with the CLI option that sets each (for the refusal message)
KEPT = {
    "scene": "--scene",
    "rskill": "--rskill",
    "robot": "--robot",
    "seed": "--seed",
    "max_steps": "--max-steps",
    "codec": "--codec",
    "formats": "--format",
    "image_format": "--image-format",
    "mcap_compression": "--mcap-compression",
    "task": "--task",
    "instruction": "--instruction",
    "randomize": "--randomize",
}
# the encoder settings a resume keeps (record.json `video`), with the CLI option of each
ENCODER_FLAGS = {"crf": "--crf", "g": "--gop", "preset": "--preset", "pix_fmt": "--pix-fmt"}
RANGES = {"max_steps": (1, MAX_STEPS), "seed": (0, MAX_SEED), "n_episodes": (1, 10**9)}
log = logging.getLogger(__name__)
HAL_KEY = "hal"  # record.json `options` of a `record --hal ROBOT` recording: the robot (record/hal_resume.py)
DIGEST = "scene_sha256"  # the sha256 of the scene file's bytes: a scene named again must still have it (`recorded`)


@dataclass(frozen=True)
class Claim:
    """The writer lock on a recording's `--out`, taken before anything is written there."""

    out: Path
    lock: DatasetLock
    created: bool  # the folder did not exist: a run that records nothing removes it again

    def release(self, finished: int = 0) -> None:
        """Release the lock; a claim that recorded nothing leaves the folder as it found it."""
        self.lock.release()
        if finished:
            return
        state = self.out / layout.STATE_DIR
        with contextlib.suppress(OSError):  # what cannot be removed (a read-only parent) was never created
            if state.is_dir() and not state.is_symlink() and not any(state.iterdir()):
                state.rmdir()
            if self.created and self.out.is_dir() and not any(self.out.iterdir()):
                self.out.rmdir()


def claim(out: Path, purpose: str, resume: bool) -> Claim:
    """Take `out`'s writer lock before any byte goes into it, and decide under it whether the run may write.

    A loser of a race exits with `DatasetBusy` naming the holder and changes nothing. A fresh recording refuses
    a folder that already holds a dataset or anything else (`OutputExists`) before touching it, and again under
    the lock (a writer that finished in between). Orphaned staging folders of killed runs beside `out` go.
    """
    if resume and out.is_dir():
        refuse_outside_links(out, "record --resume")  # before the lock: nothing is touched
    if not resume:
        busy = holder(out) if out.is_dir() else None
        if busy is not None:
            raise DatasetBusy(out, busy)
        check_out(out)
    created = not out.exists()
    try:
        lock = DatasetLock(out, purpose).acquire()
    except OSError as exc:
        Claim(out, DatasetLock(out, purpose), created).release()
        raise unwritable(out, exc) from None
    taken = Claim(out, lock, created)
    try:
        if not resume:
            check_out(out)  # again, under the lock: nothing may have appeared meanwhile
        clean_orphans(out.parent)
    except BaseException:
        taken.release()
        raise
    return taken


@dataclass(frozen=True)
class Output:
    """The locked output of a recording: where the next episode's number starts."""

    claim: Claim
    first_episode: int
    fresh: bool  # a new recording (not --resume)
    actions: list[str]  # what recovery did


def settings_path(out: Path) -> Path:
    return out / layout.RECORD_PATH


def continue_options(opts: RecordOptions, explicit: frozenset[str]) -> RecordOptions:
    """The options of the recording in `opts.out`, with `--n-episodes` from `opts` when given."""
    if opts.out is None:
        raise UsageError("--resume needs --out: the dataset folder to continue")
    path = settings_path(opts.out)
    saved = read_settings(opts.out).get("options")
    if not isinstance(saved, dict):
        raise DatasetError(f"{path}: options: missing or not a mapping", code="dataset.invalid")
    if HAL_KEY in saved:
        raise ConfigError(
            f"{path}: {HAL_KEY}: recorded with --hal {saved[HAL_KEY]}; continue it with record --hal "
            f"{saved[HAL_KEY]} --resume --out {opts.out}"
        )
    changes: dict[str, Any] = {}
    by_checkpoint = _same_policy(opts.policy, saved.get("policy"), path)
    for name, flag in KEPT.items():
        if name == "rskill" and by_checkpoint:
            continue  # no rSkill: the checkpoint named again drives
        stored = saved.get(name)
        if name == "formats":
            stored = tuple(stored or ())
        if name == "mcap_compression":
            stored = stored or "none"  # recorded before chunks were compressed
        given = getattr(opts, name)
        if name in explicit and not _same(name, given, stored):
            shown = ",".join(given) if name == "formats" else given
            raise ConfigError(
                f"{path}: {name}: the dataset was recorded with {_show(stored)}; {flag} {shown} differs "
                + _hint(name, stored)
            )
        if name in ("scene", "rskill"):  # a manifest: never a file the dataset chose (see record/recorded.py)
            stored = given if name in explicit else recorded.trusted(name, stored, path)
        if name == "randomize" and stored not in (True, False, None):
            raise DatasetError(f"{path}: randomize: {stored!r} is not true, false or null", code="dataset.invalid")
        if name == "scene" and "scene" in explicit:
            recorded.unchanged(str(given), saved.get(DIGEST), path)
        changes[name] = stored
    if "n_episodes" not in explicit:
        changes["n_episodes"] = saved.get("n_episodes")
    for name, (low, high) in RANGES.items():  # numbers from the file: whole and in range before anything runs
        value = changes.get(name) if name not in explicit else None  # (given ones: `check_run_numbers`)
        if value is not None and (type(value) is not int or not low <= value <= high):
            raise DatasetError(
                f"{path}: {name}: {value!r} is not a whole number in {low}..{high}", code="dataset.invalid"
            )
    changes["video"] = recorded_video(opts.video, saved.get("video"), explicit, path, changes["codec"])
    return replace(opts, **changes)


def _same_policy(given: str | None, stored: object, path: Path) -> bool:
    """Whether the recording was made with `record --policy`; if so, the checkpoint must be named again (record.json
    never chooses one) and be the recorded folder; `--policy` on a recording made with an rSkill is refused."""
    if stored is None and given is None:
        return False
    if not isinstance(stored, str):
        raise ConfigError(f"{path}: policy: the dataset was recorded with an rSkill; --policy {given} differs")
    if given is None:
        raise ConfigError(f"{path}: policy: recorded with the checkpoint {stored}; name it again with --policy")
    from openral_data.policies.checkpoint import open_checkpoint

    if str(open_checkpoint(given).path.resolve()) != stored:
        raise ConfigError(f"{path}: policy: the dataset was recorded with {stored}; --policy {given} differs")
    return True


def video_json(video: VideoSettings) -> dict[str, Any]:
    """The encoder settings record.json keeps (the thread budget is the machine's, not the recording's)."""
    return {name: getattr(video, name) for name in ENCODER_FLAGS}


def recorded_video(
    given_video: VideoSettings, stored: Any, explicit: frozenset[str], path: Path, codec: str
) -> VideoSettings:
    """The recording's encoder settings (a recording from before they were kept: lerobot's defaults), with this
    run's thread budget (`given_video.threads`); an encoder flag given again (`explicit`) must match."""
    if stored is None:
        return replace(VideoSettings(), codec=parse_codec(codec), threads=given_video.threads)
    try:
        if not isinstance(stored, dict) or not set(stored) <= set(ENCODER_FLAGS):
            raise TypeError(f"keys other than {', '.join(ENCODER_FLAGS)}")
        video = VideoSettings(codec=parse_codec(codec), threads=given_video.threads, **stored).resolve()
    except (TypeError, UsageError) as exc:
        raise DatasetError(f"{path}: video: {stored!r}: {exc}", code="dataset.invalid") from None
    for name, flag in ENCODER_FLAGS.items():
        cli = {"g": "gop"}.get(name, name)
        given = getattr(given_video, name)
        if cli in explicit and given != getattr(video, name):
            raise ConfigError(
                f"{path}: video.{name}: the dataset was recorded with {getattr(video, name)}; {flag} {given} differs "
                "(leave the option out to continue with the recorded one)"
            )
    return video


def read_settings(out: Path) -> dict[str, Any]:
    """``OUT/.openral/record.json``, read as one of our control files (no symlink, no FIFO, bounded)."""
    path = settings_path(out)
    try:
        doc = parse_json(atomic.read_control(path))
    except FileNotFoundError:
        raise DatasetError(f"{out}: nothing to resume (no {layout.RECORD_PATH})", code="dataset.invalid") from None
    except ValueError as exc:
        raise DatasetError(f"{path}: unreadable recording settings: {exc}", code="dataset.invalid") from None
    except OSError as exc:
        raise DatasetError(f"{path}: cannot read: {exc.strerror or exc}", code="dataset.invalid") from None
    if not isinstance(doc, dict):
        raise DatasetError(f"{path}: not a JSON object", code="dataset.invalid")
    return doc


def _same(name: str, given: Any, stored: Any) -> bool:
    """An option given again equals the recorded one; scene/rSkill references by the file each resolves to."""
    if name in ("scene", "rskill"):
        return given is not None and recorded.same(name, str(given), stored)
    return bool(given == stored)


def _hint(name: str, stored: Any) -> str:
    """How to continue after a differing option: leave it out, unless it is a manifest file that --resume may not
    take from record.json (`recorded.trusted`): that one must be named again."""
    if name in recorded.KINDS and recorded.on_search_path(name, str(stored)) is None:
        return "(name the file it was recorded with)"
    return "(leave the option out to continue with the recorded one)"


def _show(value: Any) -> str:
    return ",".join(value) if isinstance(value, tuple) else str(value)


def schema_json(schema: DatasetSchema) -> dict[str, Any]:
    return {
        "fps": schema.fps,
        "cameras": {name: [c.height, c.width] for name, c in schema.cameras.items()},
        "state contract": list(schema.state_names),
        "action contract": list(schema.action_names),
        "outcomes": {"reward": schema.has_reward, "success": schema.has_success},
    }


def open_output(claimed: Claim, opts: RecordOptions, schema: DatasetSchema, resolved: dict[str, Any]) -> Output:
    """Under the claim's lock: fresh: store the settings; resume: check the schema, recover, count episodes."""
    return open_recording(claimed, opts.resume, opts.formats, schema, resolved)


def open_recording(
    claimed: Claim, resume: bool, formats: tuple[str, ...], schema: DatasetSchema, resolved: dict[str, Any]
) -> Output:
    """`open_output` for any recording (a scene's, a HAL's): fresh: store `resolved` (the settings a resume takes
    back) and the schema; resume: check the schema, recover the sinks of `formats`, count the episodes."""
    out = claimed.out
    if not resume:
        doc = {"options": resolved, "schema": schema_json(schema)}
        atomic.write_bytes(settings_path(out), json.dumps(doc, indent=2).encode())
        return Output(claimed, 0, True, [])
    _check_schema(out, schema)
    actions, done = _recover(out, formats)
    return Output(claimed, done, False, actions)


def close_output(out: Path, output: Output, finished: int) -> None:
    """Release the lock; a fresh recording that finished nothing leaves no folder behind."""
    nothing = output.fresh and finished == 0 and all(p.name == layout.STATE_DIR for p in out.iterdir())
    if nothing:  # what this run put into `.openral/` goes; the lock file goes with the lock
        _clear(out / layout.STATE_DIR, keep=Path(layout.LOCK_PATH).name)
    output.claim.release(0 if nothing else 1)


def check_first_episode(out: Path, formats: tuple[str, ...], close: Callable[[], None]) -> None:
    """Right after a new recording's first episode is committed (the moment `out` becomes a dataset), refuse a
    LeRobot dataset lerobot 0.6.1 could not load (`loadable.check_loadable`: `DatasetError`,
    ``dataset.unloadable``), once per run: later episodes come from the same writer with the same schema.

    Only for a recording that made `out` new (never `--resume`): on a refusal `close` closes the recording's sinks
    (`DatasetBridge.close`) and everything the run wrote into `out` (the episode, MCAP bags under OUT/mcap/,
    `.openral/` but the lock) goes, so the caller's claim then leaves no folder behind: nothing is published."""
    if "lerobot" not in formats:
        return
    try:
        check_loadable(out, out)
    except DatasetError:
        with contextlib.suppress(Exception):  # the refusal is the error to report
            close()
        _clear(out, keep=layout.STATE_DIR)
        _clear(out / layout.STATE_DIR, keep=Path(layout.LOCK_PATH).name)
        raise
    log.info("%s: first episode loadable by lerobot", out)


def _clear(folder: Path, keep: str) -> None:
    """Remove what `folder` holds, except the entry named `keep` (symlinks removed, never followed)."""
    for entry in folder.iterdir():
        if entry.name == keep:
            continue
        if entry.is_dir() and not entry.is_symlink():
            shutil.rmtree(entry)
        else:
            entry.unlink()


def _check_schema(out: Path, schema: DatasetSchema) -> None:
    path = settings_path(out)
    saved = read_settings(out).get("schema")
    if not isinstance(saved, dict):
        raise DatasetError(f"{path}: schema: missing or not a mapping", code="dataset.invalid")
    now = schema_json(schema)
    for field, value in now.items():
        if saved.get(field) != value:
            raise ConfigError(f"{path}: {field}: the dataset has {saved.get(field)}, this recording {value}")


def _recover(out: Path, formats: tuple[str, ...]) -> tuple[list[str], int]:
    actions: list[str] = []
    counts: dict[str, int] = {}
    if "lerobot" in formats:
        actions += recover(out)
        counts["lerobot"] = int(read_info(out).get("total_episodes", 0)) if (out / layout.INFO_PATH).is_file() else 0
    bags = bags_dir(out)
    if "mcap" in formats:
        shutil.rmtree(bags / PARTIAL, ignore_errors=True)
        found = finished_bags(bags) if bags.is_dir() else []
        names = [p.name for p in found]
        expected = [f"episode_{i:06d}" for i in range(len(found))]
        if names != expected:
            raise DatasetError(
                f"{bags}: episode bags are not numbered 0..{len(found) - 1}; cannot continue", code="dataset.invalid"
            )
        counts["mcap"] = len(found)
    done = min(counts.values(), default=0)
    if counts.get("mcap", 0) > done:
        q = Quarantine(out)
        for bag in finished_bags(bags)[done:]:
            q.move(bag)
        actions.append(f"{MCAP_SUBDIR}: bag(s) from episode {done} on set aside (LeRobot never committed them)")
    if counts.get("lerobot", done) > done:
        raise DatasetError(
            f"{out}: the LeRobot dataset holds {counts['lerobot']} episodes, the MCAP bags {done}; cannot continue",
            code="dataset.mismatch",
        )
    return actions, done
