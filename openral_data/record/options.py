"""What a `record` run is asked to do and what it did: its options, its summary and its output folder."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Literal

from openral_data import manifests
from openral_data.errors import UsageError
from openral_data.formats.codec import Codec
from openral_data.formats.lerobot_v3.encoder import VideoSettings
from openral_data.formats.mcap import ImageFormat, McapCompression
from openral_data.runtime.outdir import fresh_out
from openral_data.runtime.sinks import OutputFormat, check_outputs
from openral_data.schemas.scene import MAX_SEED, MAX_STEPS, SimScene
from openral_data.types import EpisodeRecord
from openral_data.viz import DEFAULT_PORT

Keep = Literal["all", "success"]


@dataclass(frozen=True)
class RecordOptions:
    """Typed at the edge: the CLI parses `--format`/`--image-format`/`--mcap-compression` (`parse_formats`,
    `parse_image_format`, `parse_compression`), a pipeline YAML is validated by its schema, and the object checks
    them once more when it is built (the Python API may be called from untyped code); nothing below checks them
    again."""

    scene: str = manifests.DEFAULT_SCENE
    rskill: str | None = None  # None: the scene's default_rskill (`rskill_ref`)
    policy: str | None = None  # a lerobot checkpoint folder or cached Hub repo id instead of an rSkill (`--policy`)
    robot: str | None = None
    n_episodes: int | None = None
    seed: int | None = None
    max_steps: int | None = None
    out: Path | None = None
    codec: Codec = "av1"  # the shorthand of `video.codec` (`--codec`/`--vcodec`)
    formats: tuple[OutputFormat, ...] = ("lerobot",)  # see runtime.sinks.make_sinks for the layout
    image_format: ImageFormat = "jpeg"  # MCAP camera messages
    mcap_compression: McapCompression = "zstd"  # MCAP chunks
    resume: bool = False  # continue the recording in `out` with its own settings (see openral_data.record.output)
    explicit: frozenset[str] = frozenset()  # options the user gave (with resume: they must match the recording)
    first_episode: int = 0  # MCAP bags are numbered from here (a `--workers` share; see openral_data/record/parallel)
    # a new recording's first episode checked loadable by lerobot (`output.check_first_episode`); False for a
    # `--workers` share: the merged dataset is checked when it is published
    check_first: bool = True
    save_video: bool = False  # a debug mp4 per episode in `<out>.debug/` (openral_data/viz/debug_video.py)
    save_video_dir: Path | None = None  # ... in this folder instead (implies save_video)
    view: bool = False  # --view: show the run live in rerun (openral_data/viz/live.py); never changes the dataset
    view_port: int = DEFAULT_PORT  # --view: the port a spawned viewer or the served stream listens on
    view_address: str | None = None  # --view: send to this running viewer/server instead (rerun+http://.../proxy)
    task: str | None = None  # a task of a suite scene (`--task`; see openral_data.runtime.tasks); None: the YAML's
    instruction: str | None = None  # recorded for every frame and given to the policy (`--instruction`)
    device: str | None = None  # a neural policy's torch device (`--device`; wins over the rSkill's)
    randomize: bool | None = None  # turn the scene's `randomize:` block on or off (`--randomize`); None: the YAML's
    keep: Keep = "all"  # "success": an episode that does not succeed is discarded (`--keep`, `generate`)
    # keep="success": stop once this many episodes are kept, n_episodes then caps the attempts (`generate --n`)
    keep_target: int | None = None
    video: VideoSettings = field(default_factory=VideoSettings)  # --crf, --gop, --preset, --pix-fmt, ...

    def __post_init__(self) -> None:
        check_outputs(self.formats, self.codec, self.image_format, self.mcap_compression)
        object.__setattr__(self, "video", VideoSettings.given(self.codec, video=self.video))  # decided once
        object.__setattr__(self, "codec", self.video.codec)
        if self.keep not in ("all", "success"):
            raise UsageError(f"--keep: {self.keep!r} is not all or success")
        if self.policy is not None and self.rskill is not None:
            raise UsageError("--policy, --rskill: give one (a lerobot checkpoint, or an rSkill manifest)")
        if self.keep == "success" and self.resume:
            raise UsageError("--keep success: not with --resume (the seeds of discarded episodes are not recorded)")


@dataclass(frozen=True)
class RecordSummary:
    out: Path
    episodes: list[EpisodeRecord]
    frames: int
    seconds: float
    resumed_at: int = 0  # episodes the dataset already held when this run started (--resume)
    recovered: tuple[str, ...] = ()  # what recovery did before resuming
    codec: str = ""  # the settings used (with --resume: the recording's own)
    formats: tuple[OutputFormat, ...] = ()
    debug_videos: Path | None = None  # where --save-video wrote (not in to_json)
    discarded: int = 0  # episodes not kept (`keep="success"`: they did not succeed)

    @property
    def success_rate(self) -> float:
        wins = sum(bool(e.success) for e in self.episodes if e.success is not None)
        return wins / len(self.episodes) if self.episodes else 0.0

    @property
    def fps(self) -> float:
        return self.frames / self.seconds if self.seconds > 0 else 0.0

    def to_json(self) -> dict[str, object]:
        """The fields of `record --json` (less the CLI's `workers`), in docs/scripting.md's order."""
        return {
            "out": str(self.out),
            "episodes": len(self.episodes),
            "frames": self.frames,
            "successes": sum(e.success is True for e in self.episodes),
            "success_rate": self.success_rate,
            "seconds": self.seconds,
            "frames_per_s": self.fps,
            "resumed_at": self.resumed_at,
            "recovered": list(self.recovered),
            "codec": self.codec,
            "formats": list(self.formats),
            "mcap_dir": str(self.out / "mcap") if "mcap" in self.formats else None,
            "discarded": self.discarded,
            "episode_list": [asdict(e) for e in self.episodes],
        }


ProgressFn = Callable[[EpisodeRecord | None, int, int], None]  # (finished episode | None at start, frames, total)


def check_run_numbers(n_episodes: int, max_steps: int, seed: int) -> None:
    """The counts of a recording, before anything is built: at least one episode and one step, and seeds
    seed..seed+n_episodes-1 that every simulator accepts (0..MAX_SEED)."""
    if n_episodes < 1:
        raise UsageError(f"--n-episodes must be >= 1, got {n_episodes}")
    if max_steps < 1:
        raise UsageError(f"--max-steps must be >= 1, got {max_steps}")
    if max_steps > MAX_STEPS:
        raise UsageError(f"--max-steps must be <= {MAX_STEPS}, got {max_steps}")
    if seed < 0:
        raise UsageError(f"--seed must be >= 0, got {seed}")
    if seed + n_episodes - 1 > MAX_SEED:
        raise UsageError(
            f"--seed/--n-episodes: episode seeds {seed}..{seed + n_episodes - 1} exceed {MAX_SEED} (a uint32)"
        )


DEFAULT_RSKILL = "random-mock"  # for a scene that suggests none


def rskill_ref(given: str | None, scene: SimScene) -> str:
    """The rSkill a recording uses: `--rskill`, else the scene's `default_rskill`, else `DEFAULT_RSKILL`."""
    return given or scene.scene.default_rskill or DEFAULT_RSKILL


def default_out(scene: SimScene, rskill_id: str) -> Path:
    """`datasets/<scene>-<n>` (the rSkill is in the dataset's provenance and `stats --by rskill`)."""
    del rskill_id  # the name stays short; kept in the signature for the callers
    return fresh_out(scene.scene.id)
