"""The dataset card (the repo's README.md) a push writes: lerobot 0.6.1's own card, and what we know beside it.

The front matter is what `lerobot.datasets.utils.create_lerobot_dataset_card` puts there (license,
``task_categories: [robotics]``, the ``LeRobot`` tag, a ``default`` config whose ``data_files`` are
``data/*/*.parquet``, which the Hub's dataset viewer reads) plus our ``openral-data`` tag and `--tags`; the text
is lerobot's card template (read from the installed lerobot, rendered by huggingface_hub) with its description
filled in: a summary (episodes, frames, fps, robot type, success with its 95 % Wilson interval by the one success
rule), the tasks, a features table and the provenance (openral-data's `meta/openral.json`: writer version,
scenes, rSkills, seeds, edits; else "written by LeRobot"). The text depends only on the dataset and the options, so
tests compare it whole. Local paths (a scene's file, an edit's source folder) are never published, only names.
"""

from __future__ import annotations

import importlib.util
import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from huggingface_hub import DatasetCard, DatasetCardData

from openral_data.formats.lerobot_v3 import layout
from openral_data.formats.lerobot_v3.provenance import EditRecord, Origin, Provenance, read_provenance
from openral_data.formats.lerobot_v3.reader import DatasetSummary, read_episodes, read_info, summarize
from openral_data.metrics.intervals import wilson
from openral_data.text import printable
from openral_data.version import __version__

TAGS = ["LeRobot", "openral-data"]
DATA_FILES = "data/*/*.parquet"
MAX_TASKS = 50  # a card lists this many tasks, then says how many more there are
SEED = "openral.seed"


@dataclass(frozen=True)
class CardOptions:
    repo_id: str
    license: str = "apache-2.0"  # lerobot's `push_to_hub` default
    citation: str | None = None  # BibTeX
    tags: tuple[str, ...] = ()  # more card tags (`push --tags`, lerobot's `push_to_hub(tags=...)`)


def card_data(license: str, tags: tuple[str, ...] = ()) -> DatasetCardData:
    """The YAML front matter: lerobot's (`create_lerobot_dataset_card`, whose `tags=` follow its ``LeRobot``) with
    our tag, then `tags` (each once)."""
    return DatasetCardData(
        license=license,
        tags=list(dict.fromkeys([*TAGS, *tags])),
        task_categories=["robotics"],
        configs=[{"config_name": "default", "data_files": DATA_FILES}],
    )


def dataset_card(root: Path, opts: CardOptions) -> str:
    """README.md for `root` pushed as `opts.repo_id`."""
    info = read_info(root)
    summary = summarize(root)
    meta = read_provenance(root)
    description = "\n\n".join(
        [
            _summary(summary),
            _tasks(summary.tasks),
            _features(info.get("features", {})),
            _provenance(root, meta),
        ]
    )
    structure = f"[{layout.INFO_PATH}]({layout.INFO_PATH}):\n```json\n{json.dumps(info, indent=4)}\n```\n"
    card = DatasetCard.from_template(
        card_data(opts.license, opts.tags),
        template_str=lerobot_template(),
        repo_id=opts.repo_id,
        license=opts.license,
        dataset_description=description,
        dataset_structure=structure,
        citation_bibtex=opts.citation,
    )
    return str(card).rstrip("\n") + "\n"


def lerobot_template() -> str:
    """lerobot's card_template.md, found without importing lerobot (its import loads torch)."""
    spec = importlib.util.find_spec("lerobot")
    if spec is None or not spec.submodule_search_locations:
        raise RuntimeError("lerobot is not installed")  # a dependency: a broken installation, not bad input
    return (Path(next(iter(spec.submodule_search_locations))) / "datasets" / "card_template.md").read_text()


def _summary(s: DatasetSummary) -> str:
    rows = [
        ("episodes", str(s.episodes)),
        ("frames", str(s.frames)),
        ("fps", str(s.fps)),
        ("duration", f"{s.frames / s.fps:.1f} s" if s.fps else "-"),
        ("robot type", s.robot_type or "-"),
        ("cameras", ", ".join(s.cameras) or "-"),
        ("success", success_text(s)),
    ]
    return "### Summary\n\n| | |\n|---|---|\n" + "\n".join(f"| {k} | {_cell(v)} |" for k, v in rows)


def success_text(s: DatasetSummary) -> str:
    """`1/2 episodes (50.0 %, 95 % Wilson interval 9.5 % to 90.5 %)`, with the unknown ones; `unknown` when no
    episode's outcome is known (never 0 %)."""
    if s.successes is None or s.success_known == 0:
        return "unknown (no episode records its outcome)"
    ci = wilson(s.successes, s.success_known)
    text = (
        f"{s.successes}/{s.success_known} episodes ({_pct(s.successes / s.success_known)}, "
        f"95 % Wilson interval {_pct(ci.low)} to {_pct(ci.high)})"
    )
    unknown = s.episodes - s.success_known
    return text + (f"; {unknown} episode(s) unknown" if unknown > 0 else "")


def _pct(x: float) -> str:
    return f"{100 * x:.1f} %"


def _tasks(tasks: list[str]) -> str:
    if not tasks:
        return "### Tasks\n\n(none recorded)"
    lines = [f"- {_inline(t)}" for t in tasks[:MAX_TASKS]]
    if len(tasks) > MAX_TASKS:
        lines.append(f"- ... and {len(tasks) - MAX_TASKS} more (meta/tasks.parquet)")
    return "### Tasks\n\n" + "\n".join(lines)


def _features(features: dict[str, Any]) -> str:
    cells = [(key, f.get("dtype"), _shape(f.get("shape")), _names(f.get("names"))) for key, f in features.items()]
    rows = [f"| `{_cell(k)}` | {_cell(d)} | {_cell(s)} | {_cell(n)} |" for k, d, s, n in cells]
    return "### Features\n\n| feature | dtype | shape | names |\n|---|---|---|---|\n" + "\n".join(rows)


def _shape(shape: Any) -> str:
    if not isinstance(shape, list | tuple):
        return str(shape)
    return "(" + ", ".join(str(d) for d in shape) + (",)" if len(shape) == 1 else ")")


def _names(names: Any) -> str:
    if names is None:
        return ""
    if isinstance(names, dict):  # lerobot's older {"axes": [...]} form
        return "; ".join(f"{k}: {_names(v)}" for k, v in names.items())
    if isinstance(names, list | tuple):
        return ", ".join(str(n) for n in names)
    return str(names)


def _provenance(root: Path, meta: Provenance | None) -> str:
    if meta is None:
        lines = [f"- Written by LeRobot (or another LeRobot v3 writer): it has no `{layout.OPENRAL_PATH}`."]
    else:
        version = meta.origin.openral_data_version if meta.origin is not None else None
        lines = [f"- Written by openral-data {version or '(version not recorded)'}."]
        if meta.edit is not None:
            lines.append(_edit_line(meta.edit))
        metas: list[Origin] = [m for m in [meta.origin] if m is not None]
        metas += [s.origin for s in (meta.edit.sources if meta.edit else []) if s.origin is not None]
        for label, values in (
            ("Scenes", {m.scene_id for m in metas}),
            ("rSkills", {m.rskill_id for m in metas}),
            ("Robots", {m.robot for m in metas}),
        ):
            found = sorted(v for v in values if v is not None)
            if found:
                lines.append(f"- {label}: " + ", ".join(f"`{_inline(v)}`" for v in found))
    seeds = _seeds(root)
    if seeds:
        lines.append(f"- Seeds: {seeds}")
    lines.append(f"- Card generated by openral-data {__version__}.")
    return "### Provenance\n\n" + "\n".join(lines)


def _edit_line(edit: EditRecord) -> str:
    parts = [f"`{_inline(Path(s.path or '?').name)}` (episodes {_ranges(_ints(s.episodes))})" for s in edit.sources]
    return f"- Edited with openral-data `{_inline(edit.op or '?')}` from " + (", ".join(parts) or "?") + "."


def _seeds(root: Path) -> str:
    """The episodes' seeds (our `openral.seed` column) as ranges, or "" when the dataset does not record them."""
    episodes = read_episodes(root)
    if SEED not in episodes.column_names:
        return ""
    return _ranges(_ints(episodes.column(SEED).to_pylist()))


def _ranges(values: list[int]) -> str:
    """`0-3, 7, 9-10` for the distinct values, sorted; `-` for none."""
    spans: list[list[int]] = []
    for v in sorted(set(values)):
        if spans and spans[-1][1] == v - 1:
            spans[-1][1] = v
        else:
            spans.append([v, v])
    return ", ".join(str(a) if a == b else f"{a}-{b}" for a, b in spans) or "-"


def _ints(values: Any) -> list[int]:
    return [v for v in _list(values) if isinstance(v, int) and not isinstance(v, bool)]


def _list(value: Any) -> list[Any]:
    return value if isinstance(value, list) else []


def _inline(text: str) -> str:
    """`text` on one line (a task or an id from the dataset must not break the card's Markdown), its control
    characters shown escaped (dataset text is data: no terminal sequence reaches the card or `push --dry-run`)."""
    return printable(" ".join(str(text).split()))


def _cell(value: Any) -> str:
    return _inline(str(value)).replace("|", "\\|")
