"""`replay`: options, the run over the selected episodes, the results directory and the summary.

`replay(opts, progress) -> ReplaySummary` is the Python entry point (the CLI is a thin wrapper around it).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator
from contextlib import AbstractContextManager, contextmanager
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from openral_data import manifests
from openral_data.errors import CompatibilityError, OutputExists, UsageError
from openral_data.formats.codec import Codec
from openral_data.formats.lerobot_v3 import VideoSettings
from openral_data.formats.results import is_results_dir, write_results
from openral_data.policies.base import ChunkingPolicy, PolicyAdapter
from openral_data.policies.checkpoint import (
    PolicyCheckpoint,
    as_rskill,
    check_fits,
    check_fits_scene,
    dataset_cameras,
    open_checkpoint,
)
from openral_data.policies.device import resolve_device, with_device
from openral_data.replay import recorded_policy
from openral_data.replay.actions import DEFAULT_TOLERANCE, ActionReplayer
from openral_data.replay.closed_loop import ClosedLoop
from openral_data.replay.outcome import EpisodeOutcome, overruled_line
from openral_data.replay.policy_mode import evaluate_episode
from openral_data.replay.rebuild import Rebuilt, SceneView, rebuild
from openral_data.replay.recorded import RecordedDataset
from openral_data.replay.rerecord import Rerecorder, load_view
from openral_data.replay.summary import Chunk, Extras, Mode, Run, Summary, summarize
from openral_data.replay.tables import episodes_table, steps_table
from openral_data.runtime import registry
from openral_data.runtime.compat import check_compatibility
from openral_data.runtime.observers import check_observers, make_observers
from openral_data.runtime.outdir import fresh_out
from openral_data.runtime.sinks import OutputFormat, check_outputs
from openral_data.runtime.tasks import check_instruction
from openral_data.schemas.rskill import RSkillManifest
from openral_data.viz import DEFAULT_PORT

MODES: tuple[Mode, ...] = ("actions", "policy", "closed-loop")

ProgressFn = Callable[[EpisodeOutcome | None, int, int], None]  # (finished episode | None at start, done, total)
EpisodeRunner = Callable[[int], EpisodeOutcome]


@dataclass(frozen=True)
class ReplayOptions:
    dataset: Path
    episodes: str | None = None  # "0,3,5-7"; None: all
    mode: Mode = "actions"
    rskill: str | None = None  # policy / closed-loop: an rSkill id or path; policy also `recorded[:K]`
    policy: str | None = None  # policy / closed-loop: a lerobot checkpoint folder or cached Hub repo id instead
    out: Path | None = None  # results directory (default: results/<dataset>--replay-<mode>--<time>)
    tolerance: float = DEFAULT_TOLERANCE
    label: str | None = None
    max_steps: int | None = None  # closed-loop step limit (default: the recorded task's max_steps)
    record: Path | None = None  # actions / closed-loop: also write the rollouts as a new dataset here
    cameras: Path | None = None  # with record: YAML of cameras (+ render) replacing the recorded ones
    codec: Codec = "av1"
    formats: tuple[OutputFormat, ...] = ("lerobot",)  # typed at the edge (`runtime.sinks.parse_formats`)
    instruction: str | None = (
        None  # closed-loop: the policy's instruction (and a --record's task) instead of the scene's
    )
    device: str | None = None  # policy / closed-loop: a neural policy's torch device (wins over the rSkill's)
    save_video: bool = False  # closed-loop: a debug mp4 per episode in `<results>.debug/` (viz/debug_video.py)
    save_video_dir: Path | None = None  # closed-loop: ... in this folder instead (implies save_video)
    view: bool = False  # closed-loop: show the run live in rerun (viz/live.py)
    view_port: int = DEFAULT_PORT  # --view: the port a spawned viewer or the served stream listens on
    view_address: str | None = None  # --view: send to this running viewer/server instead
    explicit: frozenset[str] = frozenset()  # the options the user gave (the CLI's parameter names)
    # `dataset` a temporary v3.0 upgrade of a v2.x one (`cli/legacy.py`): that dataset as given and its own episode
    # numbers (the upgrade's episode e is its `numbers[e]`), which the results and the summary name
    given: Path | None = None
    numbers: tuple[int, ...] = ()

    def __post_init__(self) -> None:
        check_outputs(self.formats, self.codec)  # once, when built (the Python API may be called untyped)


@dataclass
class ReplaySummary:
    out: Path
    mode: Mode
    dataset: Path
    episodes: list[EpisodeOutcome]
    seconds: float
    summary: Summary  # what summary.json holds (its `mode` is `mode`)

    def rows(self) -> list[tuple[str, str]]:
        """`key: value` lines for the CLI."""
        s, n = self.summary, len(self.episodes)
        rows = [("results", str(self.out)), ("mode", self.mode), ("episodes", str(n))]
        if s["mode"] != "policy":
            rows.append(("success recorded", f"{s['success_recorded']}/{n}"))
            rows.append(("success replayed", f"{s['success_replayed']}/{n}"))
            rows.append(("success agrees", f"{s['success_agree']}/{s['success_known']} episodes"))
        if s["mode"] == "actions":
            rows.append(("reproduced", f"{s['reproduced']}/{n} episodes (tolerance {s['tolerance']:g})"))
            rows.append(("divergence max", _num(s["divergence_max"])))
            if s["diverged_episodes"]:
                rows.append(("diverged", ", ".join(f"ep {k} at frame {v}" for k, v in s["diverged_episodes"].items())))
            rows += [("why", overruled_line(o)) for o in self.episodes if o.overruled and o.success_agrees is False]
        if s["mode"] == "closed-loop":
            p = s["paired"]
            rows.append(
                (
                    "paired",
                    f"both {p['both']}, only recorded {p['only_recorded']}, only policy {p['only_policy']}, "
                    f"neither {p['neither']}",
                )
            )
        if s["mode"] == "policy":
            rows.append(("steps compared", str(s["steps"])))
            rows.append(("action MSE", _num(s.get("action_mse_mean"))))
            rows.append(("action MAE", _num(s.get("action_mae_mean"))))
            worst = s.get("action_mae_worst")
            if worst:
                rows.append(("worst dimension", f"{worst[0]} (MAE {worst[1]:.3g})"))
            if "chunk" in s:
                rows.append(("chunks", f"executes {s['chunk']['n_action_steps']} action(s) per query"))
        if s["mode"] != "policy" and "record" in s:
            rows.append(("re-recorded", f"{s['record']['out']} ({s['record']['frames']} frames)"))
        if s["mode"] == "closed-loop" and "debug_videos" in s:
            rows.append(("debug videos", s["debug_videos"]))
        rows.append(("seconds", f"{self.seconds:.1f}"))
        return rows

    def to_json(self) -> dict[str, object]:
        """The fields of `replay --json`, in docs/scripting.md's order; a field another mode fills is null."""
        s = self.summary
        sim = s if s["mode"] != "policy" else None
        actions = s if s["mode"] == "actions" else None
        policy = s if s["mode"] == "policy" else None
        worst = policy.get("action_mae_worst") if policy is not None else None
        record = sim.get("record") if sim is not None else None
        chunk = policy.get("chunk") if policy is not None else None
        return {
            "results": str(self.out),
            "mode": self.mode,
            "dataset": str(self.dataset),
            "rskill": s["rskill"],
            "label": s["label"],
            "episodes": len(self.episodes),
            "seconds": self.seconds,
            "success_recorded": s["success_recorded"],
            "success_replayed": sim["success_replayed"] if sim is not None else None,
            "success_known": sim["success_known"] if sim is not None else None,
            "success_agree": sim["success_agree"] if sim is not None else None,
            "tolerance": sim["tolerance"] if sim is not None else None,
            "reproduced": actions["reproduced"] if actions is not None else None,
            "divergence_max": actions["divergence_max"] if actions is not None else None,
            "diverged_episodes": actions["diverged_episodes"] if actions is not None else None,
            "operator_verdicts": actions["operator_verdicts"] if actions is not None else None,
            "paired": s["paired"] if s["mode"] == "closed-loop" else None,
            "steps_compared": policy["steps"] if policy is not None else None,
            "action_mse_mean": policy.get("action_mse_mean") if policy is not None else None,
            "action_mae_mean": policy.get("action_mae_mean") if policy is not None else None,
            "action_mae_worst": None if not worst else {"name": worst[0], "mae": worst[1]},
            "chunk_n_action_steps": chunk["n_action_steps"] if chunk is not None else None,
            "rerecorded": record["out"] if record is not None else None,
            "rerecorded_frames": record["frames"] if record is not None else None,
            "episode_list": [_episode_json(o) for o in self.episodes],
        }


def _episode_json(o: EpisodeOutcome) -> dict[str, object]:
    div = o.divergence
    return {
        "index": o.index,
        "steps": o.steps,
        "success_recorded": o.success_recorded,
        "success_replayed": o.success_replayed,
        "success_agrees": o.success_agrees,
        "first_divergence_frame": o.first_divergence_frame,
        "divergence_max": float(div.max()) if div is not None and div.size else None,
    }


def _num(value: float | None) -> str:
    return "-" if value is None else f"{float(value):.3g}"


def _check(opts: ReplayOptions) -> None:
    if opts.mode not in MODES:
        raise UsageError(f"--mode: {opts.mode!r} is not one of {', '.join(MODES)}")
    if opts.rskill is not None and opts.policy is not None:
        raise UsageError("--policy, --rskill: give one (a lerobot checkpoint, or an rSkill manifest)")
    if opts.mode != "actions" and opts.rskill is None and opts.policy is None:
        raise UsageError(f"--mode {opts.mode} needs --rskill or --policy (the policy to evaluate)")
    if opts.mode == "actions" and (opts.rskill is not None or opts.policy is not None):
        flag = "--rskill" if opts.rskill is not None else "--policy"
        raise UsageError(f"{flag}: --mode actions replays the recorded actions; it takes no policy")
    if opts.mode == "closed-loop" and recorded_policy.parse(opts.rskill or "") is not None:
        raise UsageError("--rskill recorded: in closed loop that is --mode actions")
    if opts.mode == "policy" and opts.record is not None:
        raise UsageError("--record: --mode policy runs no simulator, so there is no rollout to record")
    if opts.cameras is not None and opts.record is None:
        raise UsageError("--cameras: only used with --record (the replay itself renders nothing)")
    if opts.instruction is not None and opts.mode != "closed-loop":
        raise UsageError("--instruction: only with --mode closed-loop (the other modes use the recorded frames' task)")
    check_instruction(opts.instruction)
    if opts.device is not None and opts.mode == "actions":
        raise UsageError("--device: --mode actions runs no policy")
    if opts.mode != "closed-loop" and (watched(opts) or "view_port" in opts.explicit or opts.view_address is not None):
        raise UsageError(
            f"--save-video, --view: only with --mode closed-loop (--mode {opts.mode} renders no scene to show)"
        )
    if not np.isfinite(opts.tolerance) or opts.tolerance < 0:
        raise UsageError(f"--tolerance must be a finite number >= 0, got {opts.tolerance}")
    if opts.max_steps is not None and opts.max_steps < 1:
        raise UsageError(f"--max-steps must be >= 1, got {opts.max_steps}")
    if opts.out is not None and (is_results_dir(opts.out) or (opts.out.is_dir() and any(opts.out.iterdir()))):
        raise OutputExists(f"{opts.out}: --out exists and is not empty; refusing to overwrite it (choose a new --out)")


def watched(opts: ReplayOptions) -> bool:
    """Whether `--save-video` / `--view` watch the run."""
    return opts.save_video or opts.save_video_dir is not None or opts.view


def replay(opts: ReplayOptions, progress: ProgressFn | None = None) -> ReplaySummary:
    """Replay or evaluate the selected episodes of `opts.dataset` and write the results directory."""
    _check(opts)
    dataset = RecordedDataset(opts.dataset)
    chosen = dataset.select(opts.episodes)
    dataset.need_files(chosen, pixels=opts.mode == "policy", what=f"replay --mode {opts.mode}")
    out = opts.out
    if out is None:
        out = fresh_out(f"{opts.dataset.resolve().name}-replay-{opts.mode}", manifests.results_dir())
    videos = check_observers(opts, out, what="the results")  # `--save-video`: `<results>.debug/`
    t0 = time.perf_counter()
    outcomes: list[EpisodeOutcome] = []
    extras = Extras(debug_videos=None if videos is None else str(videos))
    with _runner(opts, dataset, out, extras) as run:
        if progress is not None:
            progress(None, 0, len(chosen))
        for e in chosen:
            outcomes.append(run(e))
            if progress is not None:
                progress(outcomes[-1], len(outcomes), len(chosen))
    seconds = time.perf_counter() - t0
    if opts.numbers:  # the episodes as the user numbers them
        outcomes = [replace(o, index=opts.numbers[o.index]) for o in outcomes]
    driver = opts.rskill if opts.policy is None else f"policy:{opts.policy}"
    about = Run(opts.mode, opts.given or opts.dataset, opts.label, driver, opts.tolerance, dataset.info["features"])
    summary = summarize(about, outcomes, seconds, extras)
    write_results(out, summary, episodes_table(outcomes), steps_table(outcomes))
    return ReplaySummary(
        out=out, mode=opts.mode, dataset=about.dataset, episodes=outcomes, seconds=seconds, summary=summary
    )


def _runner(
    opts: ReplayOptions, dataset: RecordedDataset, out: Path, extras: Extras
) -> AbstractContextManager[EpisodeRunner]:
    """A function replaying one episode in the chosen mode (results in `out`); everything it opened is closed on
    exit."""
    if opts.mode == "policy":
        return _offline(opts, dataset, extras)
    return _simulated(opts, dataset, out, extras)


@contextmanager
def _offline(opts: ReplayOptions, dataset: RecordedDataset, extras: Extras) -> Iterator[EpisodeRunner]:
    """Policy mode: the policy judged on the recorded frames, no simulator; closed on exit."""
    offline = _policy_for_dataset(opts, dataset)
    if isinstance(offline, ChunkingPolicy):
        extras.chunk = Chunk(n_action_steps=int(offline.n_action_steps))
    try:
        yield lambda e: evaluate_episode(dataset, e, offline)
    finally:
        offline.close()


@contextmanager
def _simulated(opts: ReplayOptions, dataset: RecordedDataset, out: Path, extras: Extras) -> Iterator[EpisodeRunner]:
    """Actions or closed-loop mode: each episode run in the rebuilt scene (re-recorded or watched when asked);
    the re-recorder, the policy and the scene are closed on exit, in that order."""
    checkpoint = open_checkpoint(opts.policy) if opts.policy is not None else None
    manifest, rskill_src = (
        (None, None) if opts.mode == "actions" or checkpoint is not None else _resolve(opts.rskill or "")
    )
    if checkpoint is not None:  # the recording's rSkill says what its state and action mean; the sizes: check_fits
        manifest, rskill_src = as_rskill(checkpoint, dataset.rskill()), str(checkpoint.config_file)
    built = rebuild(dataset, manifest, _view(opts), rskill_src)
    rerec: Rerecorder | None = None
    policy: PolicyAdapter | None = None
    ok = False
    try:
        if opts.mode == "actions":
            replayer = ActionReplayer(built.env, opts.tolerance)
        else:
            assert manifest is not None
            policy = _open_policy(opts, built, manifest, str(rskill_src), checkpoint)
            max_steps = opts.max_steps if opts.max_steps is not None else built.scene.task.max_steps
            loop = ClosedLoop(built.env, policy, max_steps, opts.tolerance, opts.instruction)
        if opts.record is not None or watched(opts):
            rerec = Rerecorder(
                opts.record,
                built,
                dataset.root,
                opts.mode,
                opts.codec,
                opts.formats,
                observe=lambda schema: make_observers(opts, out, schema),
            )

        def run(e: int) -> EpisodeOutcome:
            episode = dataset.episode(e)
            hook = rerec.begin(episode.seed, episode.index) if rerec is not None else None
            outcome = replayer.replay(episode, hook) if opts.mode == "actions" else loop.run(episode, hook)
            if rerec is not None:
                rerec.end()
            return outcome

        yield run
        ok = True
    finally:
        try:
            if rerec is not None:
                extras.record = rerec.close(ok)
            if policy is not None:
                policy.close()
        finally:
            built.env.close()


def _view(opts: ReplayOptions) -> SceneView:
    """What the rebuilt scene renders: `--cameras`' YAML, the recorded cameras when the run is recorded or closed
    loop, else nothing."""
    if opts.cameras is not None:
        return load_view(opts.cameras)
    return SceneView() if opts.record is not None or opts.mode == "closed-loop" else SceneView(cameras=())


def _open_policy(
    opts: ReplayOptions, built: Rebuilt, manifest: RSkillManifest, rskill_src: str, checkpoint: PolicyCheckpoint | None
) -> PolicyAdapter:
    """The rSkill's (or `--policy`'s) policy for closed loop, once its contract is checked against the rebuilt
    scene."""
    if checkpoint is not None:
        check_fits_scene(checkpoint, built.env.spec, manifest, f"scene {built.source}")
    check_compatibility(
        built.robot,
        manifest,
        built.env.spec,
        rskill_source=rskill_src,
        scene_source=built.source,
        video=VideoSettings(codec=opts.codec),
    )
    device = resolve_device(opts.device) if opts.device is not None else None
    return registry.policy_factory(manifest, rskill_src)(with_device(manifest, device))


def _resolve(ref: str) -> tuple[RSkillManifest, str]:
    manifest, path = registry.resolve_rskill(ref)
    return manifest, str(path)


def _policy_for_dataset(opts: ReplayOptions, dataset: RecordedDataset) -> PolicyAdapter:
    """`recorded[:K]`, or the rSkill's (or `--policy`'s) policy after checking its contract against what the
    dataset holds."""
    device = resolve_device(opts.device) if opts.device is not None else None
    features = dataset.info["features"]
    if opts.policy is not None:
        checkpoint = open_checkpoint(opts.policy)
        check_fits(
            checkpoint,
            f"dataset {dataset.root}",
            state_dim=int(features["observation.state"]["shape"][0]),
            action_dim=int(features["action"]["shape"][0]),
            cameras=dataset_cameras(features),
            fps=dataset.fps,
        )
        manifest = with_device(as_rskill(checkpoint, None), device)
        return registry.policy_factory(manifest, str(checkpoint.config_file))(manifest)
    ref = opts.rskill or ""
    chunk = recorded_policy.parse(ref)
    if chunk is not None:
        return recorded_policy.RecordedActions(chunk)
    manifest, src = _resolve(ref)
    manifest = with_device(manifest, device)
    for side, key, contract in (
        ("state_contract", "observation.state", manifest.state_contract),
        ("action_contract", "action", manifest.action_contract),
    ):
        have = int(features[key]["shape"][0])
        if have != contract.dim:
            raise CompatibilityError(
                f"{src}: {side}.dim: {contract.dim} but dataset {dataset.root} records {key} of {have} dims"
            )
    missing = [c for c in manifest.required_cameras if c not in dataset.cameras]
    if missing:
        raise CompatibilityError(
            f"{src}: required_cameras: {missing} not in dataset {dataset.root} (it has {dataset.cameras})"
        )
    return registry.policy_factory(manifest, src)(manifest)
