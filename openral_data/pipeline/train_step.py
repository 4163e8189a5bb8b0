"""The `train` step: lerobot's trainer (`trainer.py`) on each dataset the reference names.

Per dataset item NAME the training run lives in `<step>/.NAME.training/run/` (`lerobot-train`'s output folder:
`checkpoints/<step>/`, `checkpoints/last`; its output in `.NAME.training/lerobot-train.log`), outside the
item's staging folder, so a run killed at any point (SIGKILL included) resumes from lerobot's last checkpoint
(`lerobot-train --resume`) when the pipeline is run again; a run made with other settings or on
another dataset (its `run.json` says which) is started over. When training ends, the output item is
`pretrained_model/` (the last checkpoint: what `record --policy` and `replay --policy` load) and
`provenance.json`: the dataset and its digest, the settings, lerobot's `train_config.json`, and the lerobot,
torch and openral-data versions.
"""

from __future__ import annotations

import hashlib
import json
import shutil
from collections.abc import Callable, Iterator
from dataclasses import asdict
from pathlib import Path
from typing import Any

from openral_data.formats.atomic import write_bytes
from openral_data.formats.lerobot_v3 import digests
from openral_data.paths import contained
from openral_data.pipeline.schema import TrainStep
from openral_data.pipeline.trainer import MODULE, TrainSettings, train_policy

ItemJob = tuple[str, Callable[[Path], dict[str, Any]]]
RUN_FILE = "run.json"  # in the training folder: the settings and dataset digest it was started with
RUN_DIR = "run"  # in the training folder: lerobot-train's --output_dir


def settings_of(spec: TrainStep) -> TrainSettings:
    return TrainSettings(
        policy=spec.policy,
        steps=spec.steps,
        batch_size=spec.batch_size,
        seed=spec.seed,
        save_freq=spec.save_freq or min(spec.steps, 1000),
        device=spec.device,
        chunk_size=spec.chunk_size,
        n_action_steps=spec.n_action_steps or spec.chunk_size,
        dim_model=spec.dim_model,
        dim_feedforward=spec.dim_feedforward or 4 * spec.dim_model,
        n_encoder_layers=spec.n_encoder_layers,
        lr=spec.lr,
    )


def dataset_digest(root: Path) -> str:
    """sha256 over the (relative path, content sha256) of every file our digests track: meta, data, videos."""
    files = sorted({p for pattern in (*digests.PATTERNS, *digests.SINGLE) for p in root.glob(pattern) if p.is_file()})
    h = hashlib.sha256()
    for path in files:
        h.update(f"{path.relative_to(root).as_posix()}\0{digests.sha256_file(path)}\n".encode())
    return h.hexdigest()


def train_jobs(spec: TrainStep, resolve: Callable[[str], list[tuple[str, Path]]]) -> Iterator[ItemJob]:
    for name, dataset in resolve(spec.dataset):

        def run(out: Path, name: str = name, dataset: Path = dataset) -> dict[str, Any]:
            return train_item(spec, name, dataset, out)

        yield name, run


def train_item(spec: TrainStep, name: str, dataset: Path, out: Path) -> dict[str, Any]:
    settings = settings_of(spec)
    digest = dataset_digest(dataset)
    work = contained(out.parent, f".{name}.training", f"train step: item {name!r}")
    started = {"settings": asdict(settings), "dataset_digest": digest}
    if (work / RUN_FILE).is_file() and json.loads((work / RUN_FILE).read_text()) != started:
        shutil.rmtree(work)  # another configuration's or another dataset's run: not resumable
    if not (work / RUN_FILE).is_file():
        work.mkdir(parents=True, exist_ok=True)
        write_bytes(work / RUN_FILE, json.dumps(started, indent=2).encode())
    checkpoint, resumed = train_policy(dataset, work / RUN_DIR, settings, spec.threads)
    out.mkdir(parents=True, exist_ok=True)
    shutil.copytree(checkpoint, out / "pretrained_model")
    provenance = {
        "dataset": str(dataset),
        "dataset_digest": digest,
        "settings": asdict(settings),
        "threads": spec.threads,
        "steps": settings.steps,
        "resumed": resumed,
        "training_folder": str(work),
        "trainer": f"python -m {MODULE} (lerobot-train)",
        "lerobot_train_config": json.loads((checkpoint / "train_config.json").read_text()),
        "versions": _versions(),
    }
    write_bytes(out / "provenance.json", json.dumps(provenance, indent=2).encode())
    return {
        "dataset": str(dataset),
        "dataset_digest": digest,
        "policy": settings.policy,
        "steps": settings.steps,
        "resumed": resumed,
        "checkpoint": str(Path(name) / "pretrained_model"),
    }


def _versions() -> dict[str, str]:
    from importlib.metadata import version

    return {pkg: version(pkg) for pkg in ("lerobot", "torch", "openral-data")}
