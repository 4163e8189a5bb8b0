"""The `replay` step: #5's `replay()` (recorded actions back through the rebuilt scene) on each dataset."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

from openral_data.pipeline.schema import ReplayStep

ItemJob = tuple[str, Callable[[Path], dict[str, Any]]]


def replay_jobs(spec: ReplayStep, resolve: Callable[[str], list[tuple[str, Path]]]) -> Iterator[ItemJob]:
    for name, dataset in resolve(spec.dataset):

        def run(out: Path, dataset: Path = dataset) -> dict[str, Any]:
            from openral_data.replay import ReplayOptions, replay

            extra: dict[str, Any] = {} if spec.tolerance is None else {"tolerance": spec.tolerance}
            opts = ReplayOptions(dataset=dataset, episodes=spec.episodes, mode=spec.mode, out=out, **extra)
            s = replay(opts).summary
            actions = s if s["mode"] == "actions" else None
            return {
                "dataset": str(dataset),
                "episodes": len(s["episodes"]),
                "success_recorded": s["success_recorded"],
                "success_replayed": s["success_replayed"],
                "success_agree": s["success_agree"],
                "reproduced": actions["reproduced"] if actions is not None else None,
                "divergence_max": actions["divergence_max"] if actions is not None else None,
            }

        yield name, run
