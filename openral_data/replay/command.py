"""`replay`: options, the run over the selected episodes, the results directory and the summary.

`replay(opts, progress) -> ReplaySummary` is the Python entry point (the CLI is a thin wrapper around it).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from datetime import datetime
from pathlib import Path
from typing import Any, Literal

import numpy as np

from openral_data import paths
from openral_data.errors import OpenralError
from openral_data.metrics.results import is_results_dir, write_results
from openral_data.replay.actions import DEFAULT_TOLERANCE, ActionReplayer
from openral_data.replay.outcome import EpisodeOutcome
from openral_data.replay.rebuild import SceneView, rebuild
from openral_data.replay.recorded import RecordedDataset
from openral_data.replay.tables import episodes_table, steps_table

Mode = Literal["actions", "policy", "closed-loop"]
MODES: tuple[Mode, ...] = ("actions", "policy", "closed-loop")
KIND = {"actions": "replay", "policy": "eval", "closed-loop": "eval"}

ProgressFn = Callable[[EpisodeOutcome | None, int, int], None]  # (finished episode | None at start, done, total)


@dataclass(frozen=True)
class ReplayOptions:
    dataset: Path
    episodes: str | None = None  # "0,3,5-7"; None: all
    mode: Mode = "actions"
    rskill: str | None = None  # policy and closed-loop modes
    out: Path | None = None  # results directory (default: results/<dataset>--<mode>--<time>)
    tolerance: float = DEFAULT_TOLERANCE
    label: str | None = None


@dataclass
class ReplaySummary:
    out: Path
    mode: Mode
    dataset: Path
    episodes: list[EpisodeOutcome]
    seconds: float
    summary: dict[str, Any] = field(default_factory=dict)  # what summary.json holds

    def rows(self) -> list[tuple[str, str]]:
        """`key: value` lines for the CLI."""
        s = self.summary
        rows = [("results", str(self.out)), ("mode", self.mode), ("episodes", str(len(self.episodes)))]
        rows.append(("success recorded", _rate(s.get("success_recorded"), len(self.episodes))))
        rows.append(("success replayed", _rate(s.get("success_replayed"), len(self.episodes))))
        rows.append(("success agrees", f"{s.get('success_agree')}/{s.get('success_known')} episodes"))
        if self.mode == "actions":
            rows.append(
                ("reproduced", f"{s['reproduced']}/{len(self.episodes)} episodes (tolerance {s['tolerance']:g})")
            )
            rows.append(("divergence max", _num(s.get("divergence_max"))))
            diverged = s.get("diverged_episodes") or {}
            if diverged:
                rows.append(("diverged", ", ".join(f"ep {k} at frame {v}" for k, v in diverged.items())))
        rows.append(("seconds", f"{self.seconds:.1f}"))
        return rows


def _rate(count: object, n: int) -> str:
    return "-" if count is None else f"{count}/{n}"


def _num(value: object) -> str:
    return "-" if value is None else f"{float(value):.3g}"  # type: ignore[arg-type]


def default_out(dataset: Path, mode: str) -> Path:
    stamp = datetime.now().strftime("%Y%m%d-%H%M%S")
    base = paths.project_root() / "results" / f"{dataset.resolve().name}--{mode}--{stamp}"
    out, k = base, 1
    while out.exists():
        k += 1
        out = base.with_name(f"{base.name}-{k}")
    return out


def _check(opts: ReplayOptions) -> None:
    if opts.mode not in MODES:
        raise OpenralError(f"--mode: {opts.mode!r} is not one of {', '.join(MODES)}")
    if opts.mode != "actions" and opts.rskill is None:
        raise OpenralError(f"--mode {opts.mode} needs --rskill (the policy to evaluate)")
    if opts.mode == "actions" and opts.rskill is not None:
        raise OpenralError("--rskill: --mode actions replays the recorded actions; it takes no policy")
    if not np.isfinite(opts.tolerance) or opts.tolerance < 0:
        raise OpenralError(f"--tolerance must be a finite number >= 0, got {opts.tolerance}")
    if opts.out is not None and (is_results_dir(opts.out) or (opts.out.is_dir() and any(opts.out.iterdir()))):
        raise OpenralError(f"{opts.out}: --out exists and is not empty; refusing to overwrite it (choose a new --out)")


def replay(opts: ReplayOptions, progress: ProgressFn | None = None) -> ReplaySummary:
    """Replay or evaluate the selected episodes of `opts.dataset` and write the results directory."""
    _check(opts)
    dataset = RecordedDataset(opts.dataset)
    chosen = dataset.select(opts.episodes)
    out = opts.out if opts.out is not None else default_out(opts.dataset, opts.mode)
    t0 = time.perf_counter()
    outcomes: list[EpisodeOutcome] = []
    if progress is not None:
        progress(None, 0, len(chosen))
    built = rebuild(dataset, view=SceneView(cameras=()))
    try:
        replayer = ActionReplayer(built.env, opts.tolerance)
        for e in chosen:
            outcomes.append(replayer.replay(dataset.episode(e)))
            if progress is not None:
                progress(outcomes[-1], len(outcomes), len(chosen))
    finally:
        built.env.close()
    seconds = time.perf_counter() - t0
    summary = _summary(opts, dataset, outcomes, seconds)
    write_results(out, summary, episodes_table(outcomes), steps_table(outcomes))
    return ReplaySummary(
        out=out, mode=opts.mode, dataset=opts.dataset, episodes=outcomes, seconds=seconds, summary=summary
    )


def _summary(
    opts: ReplayOptions, dataset: RecordedDataset, outcomes: list[EpisodeOutcome], seconds: float
) -> dict[str, Any]:
    known = [o for o in outcomes if o.success_agrees is not None]
    s: dict[str, Any] = {
        "kind": KIND[opts.mode],
        "mode": opts.mode,
        "dataset": str(opts.dataset.resolve()),
        "label": opts.label or f"{opts.dataset.resolve().name} {opts.mode}",
        "rskill": opts.rskill,
        "episodes": [o.index for o in outcomes],
        "seconds": seconds,
        "success_recorded": sum(o.success_recorded is True for o in outcomes),
        "success_replayed": sum(o.success_replayed is True for o in outcomes),
        "success_known": len(known),
        "success_agree": sum(bool(o.success_agrees) for o in known),
    }
    if opts.mode == "actions":
        divs = [float(o.divergence.max()) for o in outcomes if o.divergence is not None and o.divergence.size]
        state_names = list(dataset.info["features"]["observation.state"].get("names") or [])
        s.update(
            {
                "tolerance": opts.tolerance,
                "tolerance_meaning": "max |replayed - recorded| over state dimensions at any compared frame",
                "reproduced": sum(o.first_divergence_frame is None and o.success_agrees is not False for o in outcomes),
                "divergence_max": max(divs) if divs else None,
                "diverged_episodes": {
                    str(o.index): o.first_divergence_frame for o in outcomes if o.first_divergence_frame is not None
                },
                "state_names": state_names,
            }
        )
    return s
