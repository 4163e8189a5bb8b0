"""The pipeline YAML, validated by pydantic: named steps whose outputs later steps address by name.

```yaml
name: push_campaign            # the run folder is runs/<name> (or --workdir)
steps:
  - id: rec                    # outputs: rec/<scene>--<rskill>[--<robot>][--<task>], one dataset per combination
    record: {scenes: [tabletop_push], rskills: [scripted-push], seeds: {start: 0, count: 5}, codec: h264}
  - id: all
    merge: {inputs: [rec], order: seed}
  - id: rep
    replay: {dataset: all}
  - id: report
    stats: {inputs: [rec, rep]}
  - id: bags
    export: {dataset: all, episodes: "0-1"}
  - id: demos                  # a source outside the run: bags, HDF5, Zarr, RLDS (or a LeRobot dataset -> MCAP)
    convert: {source: data/demo.hdf5, mapping: demo_mapping.yaml, fps: 20}
  - id: kept                   # the episodes that succeeded and that the quality scan flags nothing in
    filter: {dataset: all, success: true, unflagged: true}
  - id: policy                 # lerobot's trainer on a dataset; outputs policy/<dataset item>/pretrained_model
    train: {dataset: kept, policy: act, steps: 2000, batch_size: 8, seed: 1}
  - id: eval                   # record --policy of each checkpoint on seeds the demos never used
    evaluate: {policy: policy, scene: tabletop_push, seeds: {start: 1000, count: 20}, max_steps: 150}
  - id: corrected              # the checkpoint drives, the scene's scripted expert takes over (interventions)
    dagger: {policy: policy, scene: tabletop_push, seeds: {start: 40, count: 20}, threshold: 0.25, patience: 3}
```
A reference is a step id (every output of that step) or `step/item` (one output). A convert step's `source`
and `mapping` are paths inside the pipeline file's folder.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Annotated, Literal

from pydantic import Field, field_validator, model_validator

from openral_data.errors import ConfigError, DatasetError, UsageError
from openral_data.formats.codec import Codec
from openral_data.formats.lerobot_v3.encoder import VideoSettings
from openral_data.formats.mcap import ImageFormat, McapCompression
from openral_data.manifests import Kind, find
from openral_data.paths import contained, safe_name
from openral_data.runtime.sinks import OutputFormat
from openral_data.schemas.base import StrictModel, load_model
from openral_data.schemas.scene import MAX_SEED, MAX_STEPS

_ID = re.compile(r"^[a-z0-9][a-z0-9_-]*$")


class Seeds(StrictModel):
    start: int = Field(default=0, ge=0)
    count: int = Field(ge=1)

    @model_validator(mode="after")
    def _fit(self) -> Seeds:
        if self.start + self.count - 1 > MAX_SEED:
            raise ValueError(f"seeds {self.start}..{self.start + self.count - 1} exceed {MAX_SEED} (a uint32)")
        return self


ENCODER_FIELDS = ("vcodec", "crf", "gop", "preset", "pix_fmt", "encoder_threads")  # RecordStep's, None: unset


class RecordStep(StrictModel):
    scenes: list[str] = Field(min_length=1)
    rskills: list[str] = Field(min_length=1)
    robots: list[str] | None = None  # None: each scene's own robot
    seeds: Seeds
    max_steps: int | None = Field(default=None, ge=1, le=MAX_STEPS)
    codec: Codec = "av1"
    # the encoder settings as lerobot names them (`vcodec` is `codec`'s other name); see docs/recording.md
    vcodec: Codec | None = None
    crf: float | None = None
    gop: int | None = Field(default=None, ge=1)
    preset: int | str | None = None
    pix_fmt: str | None = None
    encoder_threads: int | None = Field(default=None, ge=1)
    formats: list[OutputFormat] = Field(default_factory=lambda: list[OutputFormat](["lerobot"]), min_length=1)
    image_format: ImageFormat = "jpeg"
    mcap_compression: McapCompression = "zstd"  # `--mcap-compression` of formats: [mcap]
    workers: int = Field(default=1, ge=1)
    executor: Literal["local", "ray"] = "local"
    tasks: list[str] | None = Field(default=None, min_length=1)  # `--task` ids swept per scene; None: the YAML's
    instruction: str | None = Field(default=None, min_length=1)  # `--instruction` of every recording
    device: str | None = None  # `--device` of a neural policy

    @field_validator("formats")
    @classmethod
    def _formats_once(cls, formats: list[OutputFormat]) -> list[OutputFormat]:
        if len(set(formats)) != len(formats):
            raise ValueError(f"a format is listed twice in {','.join(formats)}")
        return formats

    @model_validator(mode="after")
    def _encoder(self) -> RecordStep:
        if self.vcodec is not None and "codec" in self.model_fields_set and self.vcodec != self.codec:
            raise ValueError(f"codec {self.codec} and vcodec {self.vcodec} differ (they are one setting)")
        try:
            self.video_settings()  # a bad combination is found when the YAML is read, before any step runs
        except UsageError as exc:
            raise ValueError(str(exc)) from None
        return self

    def video_settings(self) -> VideoSettings:
        """The step's encoder settings (`codec:` and `vcodec:` are one setting), resolved (`auto` probed) and
        checked."""
        return VideoSettings.given(
            self.vcodec or self.codec,
            crf=self.crf,
            g=self.gop,
            preset=self.preset,
            pix_fmt=self.pix_fmt or None,
            threads=self.encoder_threads,
        )

    @field_validator("robots")
    @classmethod
    def _robot_ids(cls, robots: list[str] | None) -> list[str] | None:
        for i, robot in enumerate(robots or []):  # a robot id becomes part of an output folder's name
            _one_component(robot, f"[{i}]")
        return robots

    def items(self) -> list[tuple[str, str, str, str | None, str | None]]:
        """(output folder name, scene, rSkill, robot, task) for every combination this step records; a task's
        `/` (LIBERO's `suite/index`) is a `-` in the folder name."""
        robots: list[str | None] = list(self.robots) if self.robots else [None]
        tasks: list[str | None] = list(self.tasks) if self.tasks else [None]
        return [
            (
                f"{Path(scene).stem}--{Path(rskill).name}"
                + (f"--{robot}" if robot else "")
                + (f"--{task.replace('/', '-')}" if task else ""),
                scene,
                rskill,
                robot,
                task,
            )
            for scene in self.scenes
            for task in tasks
            for rskill in self.rskills
            for robot in robots
        ]

    @model_validator(mode="after")
    def _item_names(self) -> RecordStep:
        for name, *_ in self.items():
            _one_component(name, "output folder")
        return self


def _one_component(name: str, what: str) -> None:
    """`safe_name` as a pydantic validation error (the loader names the file and the field)."""
    try:
        safe_name(name, what)
    except DatasetError as exc:
        raise ValueError(str(exc)) from None


class MergeStep(StrictModel):
    inputs: list[str] = Field(min_length=1)
    order: Literal["input", "seed"] = "input"
    common: bool = False  # keep only the features every input has (a DAgger round's extra columns go first)


class ReplayStep(StrictModel):
    dataset: str
    mode: Literal["actions"] = "actions"
    episodes: str | None = None
    tolerance: float | None = Field(default=None, gt=0)


class StatsStep(StrictModel):
    inputs: list[str] = Field(min_length=1)
    by: str | None = None


class ExportStep(StrictModel):
    dataset: str
    to: Literal["mcap"] = "mcap"
    episodes: str | None = None
    image_format: ImageFormat = "jpeg"
    mcap_compression: McapCompression = "zstd"  # of the bags' chunks (`convert --mcap-compression`)


class ConvertStep(StrictModel):
    """`openral-data convert SOURCE OUT`: bags, HDF5, Zarr or RLDS -> a LeRobot v3 dataset (`mapping`: a mapping
    file, else the source's starting mapping; `fps`: an array source's rate when it declares none)."""

    source: str
    mapping: str | None = None
    fps: int | None = Field(default=None, ge=1)
    codec: Codec | None = None  # None: the default (av1), as `convert`
    workers: int = Field(default=1, ge=1)


class TrainStep(StrictModel):
    """lerobot's trainer (`pipeline/trainer.py`) on a dataset of the pipeline; the output is the checkpoint
    (`<item>/pretrained_model`, what `record --policy` and `replay --policy` load) and `provenance.json`. Only
    numbers and a policy type of `trainer.POLICY_TYPES`: nothing here chooses code or a path."""

    dataset: str
    policy: Literal["act"] = "act"
    steps: int = Field(ge=1, le=10_000_000)
    batch_size: int = Field(default=8, ge=1, le=4096)
    seed: int = Field(default=1000, ge=0, le=MAX_SEED)
    save_freq: int | None = Field(default=None, ge=1)  # None: min(steps, 1000)
    device: Literal["cpu", "cuda", "mps"] = "cpu"
    chunk_size: int = Field(default=20, ge=1, le=1000)
    n_action_steps: int | None = Field(default=None, ge=1, le=1000)  # None: chunk_size
    dim_model: int = Field(default=256, ge=8, le=8192)
    dim_feedforward: int | None = Field(default=None, ge=8, le=32768)  # None: 4 * dim_model
    n_encoder_layers: int = Field(default=4, ge=1, le=64)
    lr: float = Field(default=1e-4, gt=0, le=1)
    threads: int | None = Field(default=None, ge=1, le=256)  # torch's CPU threads; None: one per core

    @model_validator(mode="after")
    def _chunk(self) -> TrainStep:
        if self.n_action_steps is not None and self.n_action_steps > self.chunk_size:
            raise ValueError(f"n_action_steps {self.n_action_steps} exceeds chunk_size {self.chunk_size}")
        return self


class FilterStep(StrictModel):
    """`episodes filter` of a dataset with a predicate made here from typed choices (no SQL from the YAML):
    `success` keeps the episodes that succeeded, `unflagged` those the quality scan flags nothing in; `drop`
    names features the kept dataset goes without (`features remove`: a state-only policy trains without the
    camera)."""

    dataset: str
    success: bool = True
    unflagged: bool = True
    drop: list[Annotated[str, Field(pattern=r"^[A-Za-z0-9_.\-]{1,200}$")]] = Field(default_factory=list, max_length=64)

    @model_validator(mode="after")
    def _something(self) -> FilterStep:
        if not (self.success or self.unflagged):
            raise ValueError("filter: set success or unflagged (or both)")
        return self

    def predicate(self) -> str:
        return " AND ".join(p for p, on in (("success", self.success), ("NOT quality.flagged", self.unflagged)) if on)


class EvaluateStep(StrictModel):
    """`record --policy CHECKPOINT` of every checkpoint a train step made, on `scene` from `seeds` (seeds the
    training never saw: the scene draws its initial state from the seed); the output is the rollouts' dataset,
    whose success rate `stats` reports with its Wilson interval."""

    policy: str  # a train step (or one of its items)
    scene: str
    robot: str | None = None
    seeds: Seeds
    max_steps: int | None = Field(default=None, ge=1, le=MAX_STEPS)
    codec: Codec = "h264"
    device: Literal["cpu", "cuda", "mps"] = "cpu"

    @field_validator("robot")
    @classmethod
    def _robot_id(cls, robot: str | None) -> str | None:
        if robot is not None:
            _one_component(robot, "robot")
        return robot


class DaggerStep(StrictModel):
    """The DAgger round (pipeline/dagger_step.py): each checkpoint a train step made drives `scene` from `seeds`
    and the scene's scripted expert (`expert`, else the scene's default rSkill) takes over through the teleop
    path (`--teleop expert`) when the policy departs from it by more than `threshold` (a share of the action's
    range) for `patience` ticks, and hands back after `hold` ticks; the output is a dataset whose frames the
    expert drove are marked `openral.intervention`."""

    policy: str  # a train step (or one of its items)
    scene: str
    expert: str | None = None
    seeds: Seeds
    max_steps: int | None = Field(default=None, ge=1, le=MAX_STEPS)
    threshold: float = Field(default=0.25, ge=0)
    patience: int = Field(default=3, ge=1, le=MAX_STEPS)
    hold: int = Field(default=20, ge=1, le=MAX_STEPS)
    codec: Codec = "h264"
    device: Literal["cpu", "cuda", "mps"] = "cpu"


KINDS = ("record", "merge", "replay", "stats", "export", "convert", "train", "filter", "evaluate", "dagger")
# what a step's outputs are, for checking references
PRODUCES = {
    "record": "dataset",
    "merge": "dataset",
    "replay": "results",
    "stats": "report",
    "export": "bags",
    "convert": "dataset",
    "train": "checkpoint",
    "filter": "dataset",
    "evaluate": "dataset",
    "dagger": "dataset",
}


class Step(StrictModel):
    id: str
    record: RecordStep | None = None
    merge: MergeStep | None = None
    replay: ReplayStep | None = None
    stats: StatsStep | None = None
    export: ExportStep | None = None
    convert: ConvertStep | None = None
    train: TrainStep | None = None
    filter: FilterStep | None = None
    evaluate: EvaluateStep | None = None
    dagger: DaggerStep | None = None

    @model_validator(mode="after")
    def _one_kind(self) -> Step:
        if not _ID.match(self.id):
            raise ValueError(f"id {self.id!r}: use lower-case letters, digits, '_' and '-'")
        given = [k for k in KINDS if getattr(self, k) is not None]
        if len(given) != 1:
            raise ValueError(f"step {self.id!r}: give exactly one of {', '.join(KINDS)} (got {given or 'none'})")
        return self

    @property
    def kind(self) -> str:
        return next(k for k in KINDS if getattr(self, k) is not None)

    def references(self) -> list[tuple[str, str, tuple[str, ...]]]:
        """(field, reference, kinds of output it may name) for every input of this step."""
        if self.merge is not None:
            return [(f"merge.inputs[{i}]", r, ("dataset",)) for i, r in enumerate(self.merge.inputs)]
        if self.replay is not None:
            return [("replay.dataset", self.replay.dataset, ("dataset",))]
        if self.stats is not None:
            return [(f"stats.inputs[{i}]", r, ("dataset", "results")) for i, r in enumerate(self.stats.inputs)]
        if self.export is not None:
            return [("export.dataset", self.export.dataset, ("dataset",))]
        if self.train is not None:
            return [("train.dataset", self.train.dataset, ("dataset",))]
        if self.filter is not None:
            return [("filter.dataset", self.filter.dataset, ("dataset",))]
        if self.evaluate is not None:
            return [("evaluate.policy", self.evaluate.policy, ("checkpoint",))]
        if self.dagger is not None:
            return [("dagger.policy", self.dagger.policy, ("checkpoint",))]
        return []


class Pipeline(StrictModel):
    name: str
    description: str | None = None
    steps: list[Step] = Field(min_length=1)


def load_pipeline(path: Path) -> Pipeline:
    pipeline = load_model(Pipeline, path)
    if not _ID.match(pipeline.name):
        raise ConfigError(f"{path}: name: {pipeline.name!r}: use lower-case letters, digits, '_' and '-'")
    seen: dict[str, str] = {}
    for i, step in enumerate(pipeline.steps):
        if step.id in seen:
            raise ConfigError(f"{path}: steps[{i}].id: {step.id!r} is used by an earlier step")
        for field, ref, kinds in step.references():
            target = ref.split("/", 1)[0]
            if target not in seen:
                valid = ", ".join(seen) or "none"
                raise ConfigError(f"{path}: steps[{i}].{field}: {ref!r} is not an earlier step (earlier: {valid})")
            if PRODUCES[seen[target]] not in kinds:
                raise ConfigError(
                    f"{path}: steps[{i}].{field}: {ref!r} is a {seen[target]} step; expected a step producing "
                    f"{' or '.join(kinds)}"
                )
        seen[step.id] = step.kind
    return _anchored(pipeline, path)


_MANIFEST_REFS: tuple[Kind, ...] = ("scenes", "rskills")  # a record step's fields naming manifests


def _anchored(pipeline: Pipeline, path: Path) -> Pipeline:
    """Each record step's scenes and rSkills as manifest ids or as paths inside the pipeline file's folder.

    A pipeline file is untrusted (docs/threat-model.md) and an rSkill names the policy code we load, so a
    reference is a manifest id on the search path or a file the pipeline's own folder contains (after
    symlinks, `paths.contained`), anchored there (not at the working directory); anything else is refused here.
    """
    folder = path.absolute().parent
    steps = []
    for i, step in enumerate(pipeline.steps):
        if step.convert is not None:
            steps.append(_anchored_convert(step, step.convert, folder, f"{path}: steps[{i}].convert"))
            continue
        if step.evaluate is not None:
            scene = _manifest_ref("scenes", step.evaluate.scene, folder, f"{path}: steps[{i}].evaluate.scene")
            steps.append(step.model_copy(update={"evaluate": step.evaluate.model_copy(update={"scene": scene})}))
            continue
        if step.dagger is not None:
            steps.append(_anchored_dagger(step, step.dagger, folder, f"{path}: steps[{i}].dagger"))
            continue
        spec = step.record
        if spec is None:
            steps.append(step)
            continue
        where = f"{path}: steps[{i}].record"
        refs: dict[str, list[str]] = {
            kind: [_manifest_ref(kind, r, folder, f"{where}.{kind}[{j}]") for j, r in enumerate(getattr(spec, kind))]
            for kind in _MANIFEST_REFS
        }
        steps.append(step.model_copy(update={"record": spec.model_copy(update=refs)}))
    return pipeline.model_copy(update={"steps": steps})


def _anchored_convert(step: Step, spec: ConvertStep, folder: Path, where: str) -> Step:
    """A convert step's source and mapping as paths inside the pipeline file's folder (after symlinks), else
    refused (one line)."""
    source = str(contained(folder, spec.source, f"{where}.source"))
    mapping = str(contained(folder, spec.mapping, f"{where}.mapping")) if spec.mapping is not None else None
    return step.model_copy(update={"convert": spec.model_copy(update={"source": source, "mapping": mapping})})


def _anchored_dagger(step: Step, spec: DaggerStep, folder: Path, where: str) -> Step:
    """A DAgger step's scene and expert rSkill as manifest ids or paths inside the pipeline's folder."""
    scene = _manifest_ref("scenes", spec.scene, folder, f"{where}.scene")
    expert = _manifest_ref("rskills", spec.expert, folder, f"{where}.expert") if spec.expert is not None else None
    return step.model_copy(update={"dagger": spec.model_copy(update={"scene": scene, "expert": expert})})


def _manifest_ref(kind: Kind, ref: str, folder: Path, source: str) -> str:
    """`ref` as a file or folder inside `folder` (its absolute path), else as a manifest id; else refused."""
    try:
        inside = contained(folder, ref, source)
    except DatasetError as exc:
        if find(kind, ref) is not None:
            return ref
        raise ConfigError(f"{exc}; name a manifest id or a path inside the pipeline's folder") from None
    if inside.exists():
        return str(inside)
    if find(kind, ref) is not None:
        return ref
    what = "a scene" if kind == "scenes" else "an rSkill"
    raise ConfigError(f"{source}: {ref!r} is neither {what} id on the manifest search path nor a path in {folder}")
