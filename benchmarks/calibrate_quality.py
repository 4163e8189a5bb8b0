"""Calibrate `openral-data quality` on a labelled corpus (`quality_corpus.py`): per check, the share of clean
episodes it flags, and per fault kind the share of injected faults found at the right frames.

A fault counts as **found** when the faulty episode has a flagging finding of the check expected for its kind
(`EXPECTED`) about the injected subject (the dimension, or the camera; findings about the whole episode or the
timestamps count for any subject) whose frames are within `--tolerance` (2) of the truth: the finding's span
reaches the truth's span within 2 frames on both sides and starts or ends within 2 frames of it (a clean episode
already idle for 3 frames before an injected idle head makes a longer, still right, idle span); spans of one
check and subject closer than 2 frames are joined first. Quality runs at its default stride (5: the engine places
a camera span within stride // 2 of its edges). At stride 1 every sim expert episode is `camera_frozen`: two
consecutive rendered frames of a slow arm differ by less than `frozen_diff`, a threshold set for samples 5 apart.

The corpus is split in two halves: within each kind of data (expert, generated, person) the units alternate in
order (sources by name, episodes by index): even ones tune, odd ones are held out. Thresholds are swept on the
tuning half only (`--sweep`: each threshold of `Thresholds` that governs a check, at 1/4, 1/2, 1, 2 and 4 times
its default, the others at their defaults); for each, the value kept is the one finding the most faults among
those flagging at most 5 % of the clean tuning episodes (the default on a tie). The table is then measured on
the held-out half with the chosen thresholds.

Run (from the repository root; the corpus is cached under CORPUS and reused)::

    PYTHONPATH=$PWD MUJOCO_GL=egl .venv/bin/python benchmarks/calibrate_quality.py /tmp/qcorpus --sweep \\
        --markdown /tmp/qcorpus/table.md
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections import defaultdict
from collections.abc import Mapping
from dataclasses import asdict, fields, replace
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))
import quality_corpus as qc

from openral_data.metrics.quality import DEFAULT, DEFAULT_STRIDE, FLAGS, Thresholds
from openral_data.metrics.quality.thresholds import for_kind
from tests.support import data_faults as df

# which checks each threshold governs: by the field's name, else its prefix (a field matching none is left alone)
GOVERNS = {
    "frozen_diff": "camera_frozen",
    "black_luma": "camera_black",
    "saturated_luma": "camera_saturated",
    "blur_var": "camera_blurred",
    "camera_flag": "camera_",
    "idle": "idle",
    "frozen": "frozen",
    "jerk": "jerky",
    "chatter": "chatter",
    "clip": "clipped",
    "gap": "gap",
    "jitter": "jitter",
    "teleport": "teleport",
    "limit_margin": "joint_limit",
    "velocity_factor": "joint_velocity",
}
# the engine's kind of data (`thresholds.data_kind`) of each kind of data in the corpus: a rewritten corpus dataset
# has no provenance, so the calibration passes that kind's thresholds itself
ENGINE_KIND = {"expert": "scripted", "generated": "scripted", "person": "person"}
STRIDE = DEFAULT_STRIDE  # what `quality` measures by default (camera spans are placed within stride // 2)
FACTORS = (0.25, 0.5, 1.0, 2.0, 4.0)
MAX_CLEAN = 0.05


def evaluate(
    work: Path, units: list[qc.Unit], kinds: tuple[str, ...], th: Mapping[str, Thresholds], tol: int, half: str | None
) -> dict[str, Any]:
    """Clean flags and faults found over `units` (of `half`, or all), each under the thresholds `th` gives its
    kind of data."""
    clean: dict[str, int] = defaultdict(int)
    by_data: dict[str, dict[str, int]] = defaultdict(lambda: defaultdict(int))  # data -> check (and "") -> count
    n_clean = 0
    faults: dict[str, list[int]] = {k: [0, 0, 0, 0] for k in kinds}  # injected, found at frames, found, new flag
    by_source: dict[str, list[qc.Unit]] = defaultdict(list)
    for u in units:
        if half is None or u.half == half:
            by_source[u.source].append(u)
    for source, mine in sorted(by_source.items()):
        mine_th = th[mine[0].data]
        base = df.findings(work / source / "clean", mine_th, STRIDE)
        for u in mine:
            n_clean += 1
            by_data[u.data][""] += 1
            for check in {f["check"] for f in base.get(u.index, [])}:
                clean[check] += 1
                by_data[u.data][check] += 1
        wanted = {u.index for u in mine}
        for kind in kinds:
            truths = [t for t in json.loads((work / source / kind / "truths.json").read_text()) if t["unit"] in wanted]
            got_in: dict[str, dict[int, list[dict[str, Any]]]] = {}
            for t in truths:  # `dataset`: a dataset of its own (`qc.ONE_PER_DATASET`), else the kind's
                sub = t.get("dataset", "")
                if sub not in got_in:
                    got_in[sub] = df.findings(work / source / kind / sub, mine_th, STRIDE)
                got = got_in[sub]
                at, anywhere = df.found(t, got.get(t["episode"], []), tol)
                before = {f["check"] for f in base.get(t["unit"], [])}
                new = bool({f["check"] for f in got.get(t["episode"], [])} - before)
                row = faults[kind]
                row[0], row[1], row[2], row[3] = row[0] + 1, row[1] + at, row[2] + anywhere, row[3] + new
    by = {d: dict(v) for d, v in by_data.items()}
    return {"clean_episodes": n_clean, "clean_flagged": dict(clean), "clean_by_data": by, "faults": faults}


def governed(name: str) -> str | None:
    if name in GOVERNS:
        return GOVERNS[name]
    for key, check in GOVERNS.items():
        if name.startswith(key):
            return check
    return None


def score(result: dict[str, Any], check: str) -> tuple[float, float]:
    """(share of clean episodes flagged by `check`, share of the faults expecting it found at their frames)."""
    n = max(1, result["clean_episodes"])
    flagged = sum(v for c, v in result["clean_flagged"].items() if c.startswith(check) or c == check) / n
    rows = [r for k, r in result["faults"].items() if any(c.startswith(check) for c in df.EXPECTED[k]) and r[0]]
    hits = sum(r[1] for r in rows) / max(1, sum(r[0] for r in rows))
    return flagged, hits


def sweep(
    work: Path, units: list[qc.Unit], kinds: tuple[str, ...], tol: int, data: str, only: tuple[str, ...] = ()
) -> tuple[Thresholds, list[str]]:
    """On the tuning units of kind of data `data`: each threshold governing a check that misses the target under
    the engine's thresholds for that kind (clean flagged > 5 %, or faults expecting it found < 95 %), tried at
    `FACTORS` of its value; the thresholds chosen and what each tried value measured."""
    units = [u for u in units if u.data == data]
    start = for_kind(DEFAULT, ENGINE_KIND[data])
    base = evaluate(work, units, kinds, {data: start}, tol, "tuning")
    chosen: dict[str, float | int] = {}
    notes = []
    for f in fields(Thresholds):
        check = governed(f.name)
        default = getattr(start, f.name)
        if check is None or not isinstance(default, int | float) or default == 0 or default >= 10**9:
            continue
        if only and f.name not in only:
            continue
        relevant = tuple(k for k in kinds if any(c.startswith(check) for c in df.EXPECTED[k]))
        clean, hits = score(base, check)
        if clean <= MAX_CLEAN and (hits >= 0.95 or not relevant):
            continue
        tried = []
        for factor in FACTORS:
            value = type(default)(default * factor) if isinstance(default, int) else default * factor
            if value == default and factor != 1.0:
                continue
            th = {data: replace(start, **{f.name: value})}
            tried.append((value, *score(evaluate(work, units, relevant, th, tol, "tuning"), check)))
        ok = [t for t in tried if t[1] <= MAX_CLEAN] or [min(tried, key=lambda t: t[1])]
        best = max(ok, key=lambda t: (t[2], t[0] == default, -t[1]))
        if best[0] != default:
            chosen[f.name] = best[0]
        notes.append(f"{data}: {f.name}: " + ", ".join(f"{v:g} -> clean {c:.0%} found {h:.0%}" for v, c, h in tried))
        print(notes[-1], flush=True)
    return replace(start, **chosen), notes


def markdown(result: dict[str, Any], th: Mapping[str, Thresholds], units: list[qc.Unit], half: str) -> str:
    mine = [u for u in units if u.half == half]
    counts = defaultdict(int)
    for u in mine:
        counts[u.data] += 1
    lines = [
        f"Held-out half: {len(mine)} clean episodes ({', '.join(f'{n} {d}' for d, n in sorted(counts.items()))}).",
        "",
        "| check | clean episodes flagged |",
        "|---|---|",
    ]
    data = sorted(result["clean_by_data"])
    lines[-2:] = [
        f"| check | clean episodes flagged | {' | '.join(data)} |",
        "|---|---|" + "---|" * len(data),
    ]
    n = max(1, result["clean_episodes"])
    checks = sorted(set(FLAGS) | set(result["clean_flagged"]))  # every flag, raised on clean episodes or not
    for check in checks:
        per = [result["clean_by_data"][d].get(check, 0) / result["clean_by_data"][d][""] for d in data]
        cells = " | ".join(f"{v:.0%}" for v in per)
        lines.append(f"| {check} | {result['clean_flagged'].get(check, 0) / n:.0%} | {cells} |")
    lines += [
        "",
        "| fault kind | expected check | injected | found at the frames (±2) | expected check raised | any new flag |",
        "|---|---|---|---|---|---|",
    ]
    for kind, (total, at, anywhere, new) in result["faults"].items():
        if total:
            lines.append(
                f"| {kind} | {' / '.join(df.EXPECTED[kind])} | {total} | {at / total:.0%} | {anywhere / total:.0%} "
                f"| {new / total:.0%} |"
            )
        else:
            lines.append(f"| {kind} | {' / '.join(df.EXPECTED[kind])} | 0 (no episode it applies to) | | | |")
    lines.append("")
    for data, t in sorted(th.items()):
        changed = {k: v for k, v in asdict(t).items() if v != getattr(DEFAULT, k)}
        lines.append(f"Thresholds for {data} ({ENGINE_KIND[data]}): {changed or 'the defaults'}.")
    return "\n".join(lines)


def corpus(args: argparse.Namespace) -> tuple[list[qc.Unit], Path]:
    root: Path = args.corpus
    work = root / "work"
    sources = [
        *qc.expert_sources(root, tuple(args.scenes), args.episodes),
        *qc.hal_sources(root, args.episodes),
        *qc.generated_source(root, args.episodes),
        *qc.person_sources(root),
        *qc.teleop_source(root, args.episodes),
    ]
    units: list[qc.Unit] = []
    counter: dict[str, int] = {}
    for src in sorted(sources, key=lambda s: (s.data, s.name)):
        saved = work / src.name / "units.json"
        if saved.is_file() and all(qc.built(work / src.name / k, k) for k in args.kinds):
            mine = [qc.Unit(**u) for u in json.loads(saved.read_text())]
            counter[src.data] = counter.get(src.data, 0) + len(mine)
        else:
            t0 = time.monotonic()
            cleans, mine = qc.source_units(src, args.max_frames, args.max_side, counter)
            if not cleans:
                continue
            qc.build(src, work, tuple(args.kinds), cleans)
            saved.write_text(json.dumps([asdict(u) for u in mine]))
            print(f"{src.name}: {len(mine)} units, built in {time.monotonic() - t0:.0f} s", flush=True)
        units += mine
    return units, work


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("corpus", type=Path, help="folder the corpus is cached in (made when missing)")
    p.add_argument("--episodes", type=int, default=4, help="expert episodes per scene, generation attempts")
    p.add_argument("--scenes", nargs="*", default=list(qc.EXPERT_SCENES))
    p.add_argument("--kinds", nargs="*", default=list(df.KINDS))
    p.add_argument("--max-frames", type=int, default=300)
    p.add_argument("--max-side", type=int, default=96)
    p.add_argument("--tolerance", type=int, default=2)
    p.add_argument("--sweep", action="store_true", help="choose thresholds on the tuning half")
    p.add_argument("--sweep-only", nargs="*", default=[], help="sweep only these thresholds (names)")
    p.add_argument("--held-out-only", action="store_true", help="measure the held-out half only (no tuning half)")
    p.add_argument("--markdown", type=Path, help="write the held-out table here")
    p.add_argument("--results", type=Path, help="write every number as JSON here")
    args = p.parse_args()
    units, work = corpus(args)
    kinds = tuple(args.kinds)
    th = {d: for_kind(DEFAULT, ENGINE_KIND[d]) for d in sorted({u.data for u in units})}
    notes: list[str] = []
    if args.sweep:
        for d in th:
            th[d], why = sweep(work, units, kinds, args.tolerance, d, tuple(args.sweep_only))
            notes += why
    tuning = None if args.held_out_only else evaluate(work, units, kinds, th, args.tolerance, "tuning")
    held = evaluate(work, units, kinds, th, args.tolerance, "held-out")
    table = markdown(held, th, units, "held-out")
    print(table)
    if args.markdown:
        args.markdown.write_text(table + "\n\nSweep (tuning half):\n\n" + "\n".join(f"- {n}" for n in notes) + "\n")
    if args.results:
        out = {"thresholds": {d: asdict(t) for d, t in th.items()}, "tuning": tuning, "held_out": held, "sweep": notes}
        args.results.write_text(json.dumps({**out, "units": [asdict(u) for u in units]}, indent=1))


if __name__ == "__main__":
    main()
