"""Malformed options: episode selections, numbers, names."""

from __future__ import annotations

from collections.abc import Callable

from tests.malformed.corpus.cases import case
from tests.support.bags import MAPPING
from tests.support.malformed import Workspace


def _argv_case(id: str, argv: Callable[[Workspace], list[str]], names: str, new: tuple[str, ...] = ()) -> None:
    case(id, argv, names, new)


SELECTIONS = {
    "open-end": "1-",
    "open-start": "-1",
    "word": "first",
    "empty": "",
    "empty-part": "0,,1",
    "duplicate": "0,0",
    "out-of-range": "5",
    "reversed": "1-0",
    "range-past-end": "0-99",
    "underscore": "1_0",
    "arabic-digit": "\u0661",
    "space-inside": "0 1",
    "huge": "9" * 5000,
    "triple-range": "0-1-2",
}
SELECTORS: dict[str, tuple[Callable[[Workspace, str], list[str]], tuple[str, ...]]] = {
    "convert": (lambda w, sel: ["convert", str(w.ds()), str(w.root / "bags"), "--episodes", sel], ("bags",)),
    "replay": (lambda w, sel: ["replay", str(w.ds()), "--episodes", sel, "--out", str(w.root / "res")], ("res",)),
    "delete": (
        lambda w, sel: ["episodes", "delete", str(w.ds()), "--episodes", sel, "--out", str(w.root / "new")],
        ("new",),
    ),
    "split": (
        lambda w, sel: ["episodes", "split", str(w.ds()), "--episodes", sel, "--out", str(w.root / "a")],
        ("a",),
    ),
    "tasks-set": (
        lambda w, sel: ["tasks", "set", str(w.ds()), "--episodes", sel, "--task", "x", "--out", str(w.root / "t")],
        ("t",),
    ),
}


def _selection_case(cmd: str, what: str, sel: str) -> None:
    argv, new = SELECTORS[cmd]
    _argv_case(f"{cmd}-select-{what}", lambda w: argv(w, sel), r"--episodes", new)


for _cmd in SELECTORS:
    for _what, _sel in SELECTIONS.items():
        _selection_case(_cmd, _what, _sel)


def _record(*extra: str) -> Callable[[Workspace], list[str]]:
    return lambda w: ["record", "--max-steps", "3", "--out", str(w.root / "o"), *extra]


def _hal(*extra: str) -> Callable[[Workspace], list[str]]:
    return lambda w: ["record", "--hal", "mock_arm", *extra, "--out", str(w.root / "o")]


def _replay(*extra: str) -> Callable[[Workspace], list[str]]:
    return lambda w: ["replay", str(w.ds()), "--out", str(w.root / "res"), *extra]


def _videos(cmd: str, *extra: str) -> Callable[[Workspace], list[str]]:
    return lambda w: ["videos", cmd, str(w.ds()), *extra, "--out", str(w.root / "v")]


OPTIONS: list[tuple[str, Callable[[Workspace], list[str]], str, tuple[str, ...]]] = [
    ("videos-codec-unknown", _videos("reencode", "--codec", "vp9"), r"--vcodec", ("v",)),
    ("videos-size-not-wxh", _videos("reencode", "--codec", "av1", "--size", "64"), r"--size", ("v",)),
    ("videos-size-too-small", _videos("reencode", "--codec", "av1", "--size", "16x16"), r"--size", ("v",)),
    ("videos-size-odd", _videos("reencode", "--codec", "h264", "--size", "33x32"), r"--size", ("v",)),
    ("videos-camera-unknown", _videos("reencode", "--codec", "av1", "--camera", "nope"), r"--camera", ("v",)),
    (
        "videos-camera-not-video",
        _videos("reencode", "--codec", "av1", "--camera", "observation.state"),
        r"--camera: observation\.state",
        ("v",),
    ),
    ("videos-out-and-in-place", _videos("reencode", "--codec", "av1", "--in-place"), r"--out", ("v",)),
    ("encode-images-codec-unknown", _videos("encode-images", "--codec", "mpeg2"), r"--vcodec", ("v",)),
    ("encode-images-camera-not-image", _videos("encode-images", "--camera", "front"), r"--camera", ("v",)),
    ("encode-images-no-image-camera", _videos("encode-images"), r"ds: has no image cameras", ("v",)),
    ("record-seed-2**70", _record("--seed", str(2**70)), r"--seed", ("o",)),
    ("record-seed-negative", _record("--seed", "-1"), r"--seed", ("o",)),
    ("record-seed-past-uint32", _record("--seed", str(2**32 - 1), "--n-episodes", "2"), r"--seed", ("o",)),
    ("record-n-episodes-negative", _record("--n-episodes", "-3"), r"--n-episodes", ("o",)),
    (
        "record-max-steps-zero",
        lambda w: ["record", "--max-steps", "0", "--out", str(w.root / "o")],
        r"--max-steps",
        ("o",),
    ),
    ("record-format-unknown", _record("--format", "hdf5"), r"--format", ("o",)),
    ("record-format-empty", _record("--format", ""), r"--format", ("o",)),
    ("record-image-format-unknown", _record("--format", "mcap", "--image-format", "gif"), r"--image-format", ("o",)),
    ("record-workers-zero", _record("--workers", "0"), r"--workers", ("o",)),
    ("record-workers-negative", _record("--workers", "-2"), r"--workers", ("o",)),
    ("record-executor-unknown", _record("--workers", "2", "--executor", "slurm"), r"--executor", ("o",)),
    ("record-mode-without-hal", _record("--mode", "real"), r"--mode", ("o",)),
    (
        "record-resume-not-a-dataset",
        lambda w: ["record", "--resume", "--out", str(w.path("empty/x").parent)],
        r"empty",
        (),
    ),
    ("record-robot-unknown", _record("--robot", "r2d2"), r"r2d2", ("o",)),
    ("record-rskill-unknown", _record("--rskill", "nope"), r"nope", ("o",)),
    ("record-scene-unknown", _record("--scene", "nowhere"), r"nowhere", ("o",)),
    ("record-scene-missing-file", _record("--scene", "missing/scene.yaml"), r"missing/scene\.yaml", ("o",)),
    ("hal-robot-unknown", lambda w: ["record", "--hal", "r2d2", "--out", str(w.root / "o")], r"r2d2", ("o",)),
    (
        "hal-fps-zero",
        _hal("--fps", "0"),
        r"--fps",
        ("o",),
    ),
    (
        "hal-fps-huge",
        _hal("--fps", str(10**6)),
        r"--fps",
        ("o",),
    ),
    (
        "hal-mode-unknown",
        _hal("--mode", "dream"),
        r"--mode",
        ("o",),
    ),
    (
        "hal-safety-unknown",
        _hal("--safety", "yolo"),
        r"--safety",
        ("o",),
    ),
    (
        "hal-staleness-nan",
        _hal("--staleness", "nan"),
        r"--staleness",
        ("o",),
    ),
    (
        "hal-staleness-negative",
        _hal("--staleness", "-1"),
        r"--staleness",
        ("o",),
    ),
    (
        "hal-seed-2**70",
        _hal("--seed", str(2**70)),
        r"--seed",
        ("o",),
    ),
    (
        "hal-resume-nothing-recorded",
        _hal("--resume"),
        r"nothing to resume \(no \.openral/record\.json\)",
        ("o",),
    ),
    ("replay-tolerance-nan", _replay("--tolerance", "nan"), r"--tolerance", ("res",)),
    ("replay-tolerance-negative", _replay("--tolerance", "-1"), r"--tolerance", ("res",)),
    ("replay-tolerance-inf", _replay("--tolerance", "inf"), r"--tolerance", ("res",)),
    ("replay-mode-unknown", _replay("--mode", "rewind"), r"--mode", ("res",)),
    ("replay-policy-without-rskill", _replay("--mode", "policy"), r"--rskill", ("res",)),
    ("replay-rskill-with-actions", _replay("--rskill", "random-mock"), r"--rskill", ("res",)),
    (
        "replay-max-steps-zero",
        _replay("--mode", "closed-loop", "--rskill", "random-mock", "--max-steps", "0"),
        r"--max-steps",
        ("res",),
    ),
    (
        "replay-format-unknown",
        lambda w: [
            "replay",
            str(w.ds()),
            "--out",
            str(w.root / "res"),
            "--record",
            str(w.root / "rec"),
            "--format",
            "avi",
        ],
        r"--format",
        ("res", "rec"),
    ),
    ("replay-cameras-without-record", _replay("--cameras", "cams.yaml"), r"--cameras", ("res",)),
    (
        "replay-dataset-missing",
        lambda w: ["replay", str(w.root / "nothing"), "--out", str(w.root / "res")],
        r"nothing",
        ("res",),
    ),
    ("stats-by-unknown", lambda w: ["stats", str(w.ds()), "--by", "colour"], r"--by", ()),
    ("stats-memory-limit-bogus", lambda w: ["stats", str(w.ds()), "--memory-limit", "lots"], r"memory", ()),
    ("stats-sql-invalid", lambda w: ["stats", str(w.ds()), "--sql", "SELEC 1"], r"", ()),
    ("stats-path-missing", lambda w: ["stats", str(w.root / "nothing")], r"nothing", ()),
    ("stats-not-a-dataset", lambda w: ["stats", str(w.path("plain/x").parent)], r"plain", ()),
    (
        "view-episode-negative",
        lambda w: ["view", str(w.ds()), "--episode", "-1", "--save", str(w.root / "v.rrd")],
        r"--episode",
        ("v.rrd",),
    ),
    (
        "view-episode-past-end",
        lambda w: ["view", str(w.ds()), "--episode", "7", "--save", str(w.root / "v.rrd")],
        r"--episode",
        ("v.rrd",),
    ),
    (
        "view-results-missing",
        lambda w: ["view", str(w.ds()), "--results", str(w.root / "nothing"), "--save", str(w.root / "v.rrd")],
        r"nothing",
        ("v.rrd",),
    ),
    (
        "view-path-missing",
        lambda w: ["view", str(w.root / "nothing"), "--save", str(w.root / "v.rrd")],
        r"nothing",
        ("v.rrd",),
    ),
    (
        "merge-order-unknown",
        lambda w: ["episodes", "merge", str(w.ds()), str(w.ds("ds2")), "--out", str(w.root / "m"), "--order", "random"],
        r"--order",
        ("m",),
    ),
    (
        "merge-not-a-dataset",
        lambda w: ["episodes", "merge", str(w.ds()), str(w.path("plain/x").parent), "--out", str(w.root / "m")],
        r"plain",
        ("m",),
    ),
    (
        "delete-every-episode",
        lambda w: ["episodes", "delete", str(w.ds()), "--episodes", "0-1", "--out", str(w.root / "new")],
        r"--episodes: 0-1 would delete every episode",
        ("new",),
    ),
    (
        "delete-in-place-and-out",
        lambda w: ["episodes", "delete", str(w.ds()), "--episodes", "0", "--in-place", "--out", str(w.root / "new")],
        r"--in-place|--out",
        ("new",),
    ),
    (
        "convert-image-format-unknown",
        lambda w: ["convert", str(w.ds()), str(w.root / "bags"), "--image-format", "gif"],
        r"--image-format",
        ("bags",),
    ),
    (
        "convert-mapping-for-dataset",
        lambda w: ["convert", str(w.ds()), str(w.root / "bags"), "--mapping", str(w.yaml("m.yaml", MAPPING))],
        r"--mapping",
        ("bags",),
    ),
    (
        "convert-episodes-for-bag",
        lambda w: ["convert", str(w.bag), str(w.root / "o"), "--episodes", "0"],
        r"--episodes",
        ("o",),
    ),
    ("convert-src-missing", lambda w: ["convert", str(w.root / "nothing"), str(w.root / "o")], r"nothing", ("o",)),
    (
        "pipeline-file-missing",
        lambda w: ["pipeline", "run", str(w.root / "nothing.yaml"), "--workdir", str(w.root / "wd")],
        r"nothing\.yaml",
        ("wd",),
    ),
    (
        "filter-where-bad-sql",
        lambda w: ["episodes", "filter", str(w.ds()), "--where", "success AND", "--out", str(w.root / "f")],
        r"--where",
        ("f",),
    ),
    (
        "filter-where-two-statements",
        lambda w: ["episodes", "filter", str(w.ds()), "--where", "1); SELECT (1", "--out", str(w.root / "f")],
        r"--where",
        ("f",),
    ),
    (
        "split-fractions-not-one",
        lambda w: ["episodes", "split", str(w.ds()), "--fractions", "0.5,0.4", "--out-dir", str(w.root / "p")],
        r"--fractions",
        ("p",),
    ),
    (
        "split-fractions-unsafe-name",
        lambda w: [
            *("episodes", "split", str(w.ds()), "--fractions", "0.5,0.5", "--names", "a,..", "--out-dir"),
            str(w.root / "p"),
        ],
        r"--names",
        ("p",),
    ),
    (
        "tasks-rename-unknown-task",
        lambda w: ["tasks", "rename", str(w.ds()), "--from", "no such task", "--to", "x", "--out", str(w.root / "t")],
        r"--from: .* has no task 'no such task'",
        ("t",),
    ),
    (
        "tasks-rename-empty-text",
        lambda w: ["tasks", "rename", str(w.ds()), "--from", "pick up the mock cube", "--to", " ", "--in-place"],
        r"--to: empty task text",
        (),
    ),
    (
        "tasks-set-empty-text",
        lambda w: ["tasks", "set", str(w.ds()), "--episodes", "0", "--task", "", "--out", str(w.root / "t")],
        r"--task: empty task text",
        ("t",),
    ),
    (
        "features-remove-unknown",
        lambda w: ["features", "remove", str(w.ds()), "--feature", "observation.nope", "--out", str(w.root / "f")],
        r"--feature: .* has no feature 'observation\.nope'",
        ("f",),
    ),
    (
        "features-remove-required",
        lambda w: ["features", "remove", str(w.ds()), "--feature", "frame_index", "--in-place"],
        r"--feature: frame_index is a column every LeRobot v3 dataset has",
        (),
    ),
    (
        "features-remove-state",
        lambda w: ["features", "remove", str(w.ds()), "--feature", "observation.state", "--out", str(w.root / "f")],
        r"--feature: observation\.state cannot be removed",
        ("f",),
    ),
    ("stats-recompute-no-output", lambda w: ["stats", "recompute", str(w.ds())], r"--out: give either", ()),
    (
        "stats-recompute-missing",
        lambda w: ["stats", "recompute", str(w.root / "gone"), "--out", str(w.root / "s")],
        r"gone",
        ("s", "gone"),
    ),
    ("info-path-is-a-file", lambda w: ["info", str(w.write("afile", "x"))], r"afile", ()),
    ("info-path-missing", lambda w: ["info", str(w.root / "nothing")], r"nothing", ()),
]
for _id, _argv, _names, _new in OPTIONS:
    _argv_case(_id, _argv, _names, _new)
