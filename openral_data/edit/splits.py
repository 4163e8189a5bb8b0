"""`episodes split --spec train=0-39,val=40-44,test=45-49 --out-dir DIR`: named episode lists, one dataset each.

A spec is `NAME=LIST` parts separated by commas, where LIST is what `--episodes` takes (`0,3,5-7`): a comma
followed by a token without `=` continues the list of the part before it (`train=0,2,4-6,val=7`). Each part is
written as `DIR/NAME` (its episodes in the order listed, re-indexed, through `ops.write_selection`: atomic,
videos copied). Refused in one line before anything is written: a malformed part, a name given twice or unfit
for a folder, an episode outside the dataset, an episode in two parts, an existing non-empty part folder.
Episodes in no part are left out.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from openral_data.edit.ops import EditResult, write_selection
from openral_data.edit.source import SourceDataset
from openral_data.episodes import parse_episodes, renumber_list
from openral_data.errors import EpisodeSelectionError, UsageError
from openral_data.formats.staging import check_new_output
from openral_data.paths import safe_name


def parse_spec(text: str) -> list[tuple[str, str]]:
    """`train=0-3,val=4,5` -> [("train", "0-3"), ("val", "4,5")] (names checked, lists not yet)."""
    parts: list[tuple[str, list[str]]] = []
    for token in (t.strip() for t in text.split(",")):
        name, sep, first = token.partition("=")
        if sep:
            parts.append((name.strip(), [first.strip()]))
        elif parts:
            parts[-1][1].append(token)
        else:
            raise UsageError(f"--spec: {text!r} does not start with NAME=EPISODES (e.g. train=0-39,val=40-44)")
    names = [safe_name(name, "--spec") for name, _ in parts]
    for name, lists in parts:
        if not name or not all(lists):
            raise UsageError(f"--spec: {name or '(no name)'}: give NAME=EPISODES, e.g. train=0-39")
    if len(set(names)) != len(names):
        raise UsageError(f"--spec: {text!r} names a part twice")
    return [(name, ",".join(lists)) for name, lists in parts]


def split_spec(dataset: Path, spec: str, out_dir: Path) -> list[EditResult]:
    """Write each named part of `spec` as `out_dir/NAME` (episodes in the order listed)."""
    parts = parse_spec(spec)
    src = SourceDataset(dataset)
    chosen: list[tuple[str, list[int]]] = []
    owner: dict[int, str] = {}
    for name, episodes in parts:
        indices = parse_episodes(episodes, src.total, f"--spec: {name}")
        for e in indices:
            if e in owner:
                raise EpisodeSelectionError(
                    f"--spec: episode {e} is in both {owner[e]} and {name}; parts must not overlap",
                    code="episodes.duplicate",
                )
            owner[e] = name
        chosen.append((name, indices))
    outs = [out_dir / name for name, _ in chosen]
    for out in outs:
        check_new_output(out, "--out-dir")  # every part's folder is checked before the first one is written
    return [write_selection([(src, e) for e in eps], out, "split") for out, (_, eps) in zip(outs, chosen, strict=True)]


def renumber_spec(spec: str, numbers: Sequence[int]) -> str:
    """`spec` typed in a LeRobot v2.x dataset's own episode numbers `numbers`, as its v3.0 upgrade numbers them
    (`episodes.renumber_list` on each part's list)."""
    if list(numbers) == list(range(len(numbers))):
        return spec
    return ",".join(f"{name}={renumber_list(lst, numbers, f'--spec: {name}')}" for name, lst in parse_spec(spec))
