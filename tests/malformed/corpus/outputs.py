"""Outputs: a file where a folder is expected, a folder below a file, a folder where a file is expected."""

from __future__ import annotations

from collections.abc import Callable

from tests.malformed.corpus.cases import case
from tests.malformed.corpus.yaml_files import pipeline_doc
from tests.support.malformed import Workspace

OUTPUTS: dict[str, tuple[Callable[[Workspace, str], list[str]], str]] = {
    "record": (lambda w, o: ["record", "--max-steps", "3", "--out", o], "--out"),
    "convert-bag": (lambda w, o: ["convert", str(w.bag), o], "DST"),
    "convert-dataset": (lambda w, o: ["convert", str(w.ds()), o], "DST"),
    "delete": (lambda w, o: ["episodes", "delete", str(w.ds()), "--episodes", "0", "--out", o], "--out"),
    "split-out": (lambda w, o: ["episodes", "split", str(w.ds()), "--episodes", "0", "--out", o], "--out"),
    "split-rest": (
        lambda w, o: ["episodes", "split", str(w.ds()), "--episodes", "0", "--out", str(w.root / "a"), "--rest", o],
        "--rest",
    ),
    "merge": (lambda w, o: ["episodes", "merge", str(w.ds()), str(w.ds("ds2")), "--out", o], "--out"),
    "filter": (lambda w, o: ["episodes", "filter", str(w.ds()), "--where", "true", "--out", o], "--out"),
    "split-fractions": (
        lambda w, o: ["episodes", "split", str(w.ds()), "--fractions", "0.5,0.5", "--out-dir", o],
        "--out-dir",
    ),
    "videos-reencode": (lambda w, o: ["videos", "reencode", str(w.ds()), "--codec", "h264", "--out", o], "--out"),
    "videos-encode-images": (lambda w, o: ["videos", "encode-images", str(w.ds()), "--out", o], "--out"),
    "replay-out": (lambda w, o: ["replay", str(w.ds()), "--out", o], "--out"),
    "replay-record": (lambda w, o: ["replay", str(w.ds()), "--out", str(w.root / "res"), "--record", o], "--record"),
    "pipeline-workdir": (
        lambda w, o: ["pipeline", "run", str(w.yaml("p.yaml", pipeline_doc(w))), "--workdir", o],
        "--workdir",
    ),
}


def _output_case(cmd: str, kind: str) -> None:
    argv, _option = OUTPUTS[cmd]

    def build(w: Workspace) -> list[str]:
        if kind == "is-a-file":
            target = w.write("taken", "precious")
        elif kind == "below-a-file":
            target = w.write("taken", "precious") / "sub"
        else:  # "not-empty"
            w.write("taken/notes.txt", "precious")
            target = w.root / "taken"
        return argv(w, str(target))

    case(f"{cmd}-output-{kind}", build, r"taken", ("a", "res") if cmd in ("split-rest", "replay-record") else ())


for _cmd in OUTPUTS:
    for _kind in ("is-a-file", "below-a-file", "not-empty"):
        # a pipeline resumes in its existing workdir; split --fractions writes new parts into an existing --out-dir
        if (_cmd, _kind) not in (("pipeline-workdir", "not-empty"), ("split-fractions", "not-empty")):
            _output_case(_cmd, _kind)

SAVES: list[tuple[str, Callable[[Workspace], list[str]], str]] = [
    ("view-save-is-a-folder", lambda w: ["view", str(w.ds()), "--save", str(w.path("taken/x").parent)], r"taken"),
    (
        "view-save-below-a-file",
        lambda w: ["view", str(w.ds()), "--save", str(w.write("taken", "x") / "v.rrd")],
        r"taken",
    ),
    ("stats-plot-is-a-folder", lambda w: ["stats", str(w.ds()), "--plot", str(w.path("taken/x").parent)], r"taken"),
    (
        "stats-plot-below-a-file",
        lambda w: ["stats", str(w.ds()), "--plot", str(w.write("taken", "x") / "p.png")],
        r"taken",
    ),
]
for _id, _argv, _names in SAVES:
    case(_id, _argv, _names)
