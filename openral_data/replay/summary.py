"""What a replay's `summary.json` holds: one `TypedDict` per mode (`ActionsSummary`, `PolicySummary`,
`ClosedLoopSummary`, told apart by `mode`) and `summarize`, which builds it once.

The key order of the JSON is the order `summarize` builds the keys in: `kind`, `mode`, the outcome counts
(`Outcomes`), then per mode the state divergence (`Divergence`, actions / closed-loop), the paired successes
(closed-loop) or the action errors (policy), then the optional parts known only while running (`Extras`:
`debug_videos`, `chunk`, `record`). `formats/results.write_results` puts `format` first.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal, NotRequired, TypedDict

import numpy as np

from openral_data.formats.lerobot_v3.features import dim_names
from openral_data.replay.outcome import EpisodeOutcome

Mode = Literal["actions", "policy", "closed-loop"]
TOLERANCE_MEANING = "max |replayed - recorded| over state dimensions at any compared frame"


class Rerecorded(TypedDict):
    """`record`: what `--record` wrote."""

    out: str
    episodes: int
    frames: int


class Chunk(TypedDict):
    """`chunk`: policy mode with a chunking policy."""

    n_action_steps: int


class Paired(TypedDict):
    """`paired`: closed-loop episodes by (recorded success, policy success)."""

    both: int
    only_recorded: int
    only_policy: int
    neither: int


class Outcomes(TypedDict):
    """The keys every mode holds after `kind` and `mode`."""

    dataset: str
    label: str
    rskill: str | None
    episodes: list[int]
    seconds: float
    success_recorded: int
    success_replayed: int
    success_known: int
    success_agree: int


class Divergence(TypedDict):
    """The state comparison of the modes that run the simulator (actions, closed-loop)."""

    tolerance: float
    tolerance_meaning: str
    reproduced: int
    divergence_max: float | None
    diverged_episodes: dict[str, int]
    operator_verdicts: list[int]  # episodes whose recorded success is an operator's verdict the scene contradicted
    state_names: list[str]


class ActionErrors(TypedDict):
    """Policy mode's compared steps and action errors per dimension (the errors absent when no step was
    compared)."""

    steps: int
    action_names: list[str]
    action_mse: NotRequired[dict[str, float]]
    action_mae: NotRequired[dict[str, float]]
    action_mse_mean: NotRequired[float]
    action_mae_mean: NotRequired[float]
    action_mae_worst: NotRequired[tuple[str, float]]  # (dimension, its MAE); a list in the JSON


class Rerecording(TypedDict):
    record: NotRequired[Rerecorded]  # with `--record`


class Watched(TypedDict):
    debug_videos: NotRequired[str]  # with `--save-video`: the folder of debug videos


class Chunked(TypedDict):
    chunk: NotRequired[Chunk]  # a chunking policy


class ActionsSummary(Outcomes, Divergence, Rerecording):
    kind: Literal["replay"]
    mode: Literal["actions"]


class ClosedLoopSummary(Outcomes, Divergence, Watched, Rerecording):
    kind: Literal["eval"]
    mode: Literal["closed-loop"]
    paired: Paired


class PolicySummary(Outcomes, ActionErrors, Chunked):
    kind: Literal["eval"]
    mode: Literal["policy"]


Summary = ActionsSummary | PolicySummary | ClosedLoopSummary


@dataclass
class Extras:
    """The optional parts, known only while running."""

    debug_videos: str | None = None  # closed-loop `--save-video`: the folder of debug videos
    chunk: Chunk | None = None  # policy mode, a chunking policy
    record: Rerecorded | None = None  # actions / closed-loop `--record`


@dataclass(frozen=True)
class Run:
    """What the summary says about the run besides its outcomes."""

    mode: Mode
    dataset: Path
    label: str | None
    rskill: str | None
    tolerance: float
    features: dict[str, Any]  # the dataset's info.json features (for the dimension names)


def summarize(run: Run, outcomes: list[EpisodeOutcome], seconds: float, extras: Extras) -> Summary:
    """The summary of `run`, in the mode's type and the JSON's key order."""
    known = [o for o in outcomes if o.success_agrees is not None]
    head = Outcomes(
        dataset=str(run.dataset.resolve()),
        label=run.label or f"{run.dataset.resolve().name} {run.mode}",
        rskill=run.rskill,
        episodes=[o.index for o in outcomes],
        seconds=seconds,
        success_recorded=sum(o.success_recorded is True for o in outcomes),
        success_replayed=sum(o.success_replayed is True for o in outcomes),
        success_known=len(known),
        success_agree=sum(bool(o.success_agrees) for o in known),
    )
    if run.mode == "policy":
        chunked = Chunked() if extras.chunk is None else Chunked(chunk=extras.chunk)
        return PolicySummary(kind="eval", mode="policy", **head, **_action_errors(run, outcomes), **chunked)
    divergence = _divergence(run, outcomes)
    rerecording = Rerecording() if extras.record is None else Rerecording(record=extras.record)
    if run.mode == "actions":
        return ActionsSummary(kind="replay", mode="actions", **head, **divergence, **rerecording)
    pairs = [(o.success_recorded is True, o.success_replayed is True) for o in outcomes]
    paired = Paired(
        both=pairs.count((True, True)),
        only_recorded=pairs.count((True, False)),
        only_policy=pairs.count((False, True)),
        neither=pairs.count((False, False)),
    )
    watched = Watched() if extras.debug_videos is None else Watched(debug_videos=extras.debug_videos)
    return ClosedLoopSummary(
        kind="eval", mode="closed-loop", **head, **divergence, paired=paired, **watched, **rerecording
    )


def _divergence(run: Run, outcomes: list[EpisodeOutcome]) -> Divergence:
    divs = [float(o.divergence.max()) for o in outcomes if o.divergence is not None and o.divergence.size]
    return Divergence(
        tolerance=run.tolerance,
        tolerance_meaning=TOLERANCE_MEANING,
        reproduced=sum(o.first_divergence_frame is None and o.success_agrees is not False for o in outcomes),
        divergence_max=max(divs) if divs else None,
        diverged_episodes={
            str(o.index): o.first_divergence_frame for o in outcomes if o.first_divergence_frame is not None
        },
        operator_verdicts=[o.index for o in outcomes if o.overruled],
        state_names=dim_names(run.features["observation.state"], "state"),
    )


def _action_errors(run: Run, outcomes: list[EpisodeOutcome]) -> ActionErrors:
    errors = [o.action_abs for o in outcomes if o.action_abs is not None and o.action_abs.size]
    names = dim_names(run.features["action"], "action")
    part = ActionErrors(steps=int(sum(len(a) for a in errors)), action_names=names)
    if errors:
        stacked = np.concatenate(errors)
        mse, mae = (stacked**2).mean(axis=0), stacked.mean(axis=0)
        keys = names if len(names) == len(mae) else [f"action_{i}" for i in range(len(mae))]
        part["action_mse"] = dict(zip(keys, mse.tolist(), strict=True))
        part["action_mae"] = dict(zip(keys, mae.tolist(), strict=True))
        part["action_mse_mean"], part["action_mae_mean"] = float(mse.mean()), float(mae.mean())
        part["action_mae_worst"] = (keys[int(mae.argmax())], float(mae.max()))
    return part
