"""Every shell example in README.md and docs/*.md is run, or says in the markdown why not.

An example is a fenced block marked bash/sh/console/shell, or any fenced block with a line starting
`openral-data ` (or `$ openral-data `). Each page's examples run in page order through the real CLI (in-process)
in one empty project folder, so earlier examples make the inputs of later ones. A transcript (`$ ` lines) is
checked against what it shows: a command followed by `error: …` must fail with exit 2 and exactly that line,
any other must succeed and print every output line shown (spacing aside; lines with `…`/`...` are elisions).
`| jq …` is not run (only the openral-data part is); `> FILE` writes the command's stdout there. Lines of
other programs (jq, cp, lerobot-train) are not run; a block with no openral-data command must be marked.

Markers, an HTML comment on the line(s) right above a block:
- `<!-- not-run: REASON -->`: the block is not run here (hardware, the Hub, LIBERO's environment, a synopsis
  with placeholders, minutes of simulation), for that reason;
- `<!-- run-by: tests/PATH.py -->`: another test runs this block as written;
- `<!-- docs-inputs: PATH=MAKER, … -->`: before running the block, PATH in the page's folder is made by MAKER
  (`INPUTS` below: inputs no openral-data command makes, e.g. a dataset written by lerobot 0.6.1 itself);
- `<!-- docs-file: NAME -->` above any block (a mapping YAML): its text is the file NAME for later examples.
A new example without a marker that cannot run fails its page's test; the marker check below fails on a marker
with no reason or one on no example. A synopsis (`not-run: synopsis …`) is checked another way: every flag it
shows is in its command's `--help`."""

from __future__ import annotations

import itertools
import json
import re
import shlex
import shutil
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pytest

from tests.support.home import REPO
from tests.support.inproc import Run, run_inproc

PAGES = ["README.md", *(f"docs/{p.name}" for p in sorted((REPO / "docs").glob("*.md")))]
SHELL = {"bash", "sh", "console", "shell"}
FENCE = re.compile(r"^\s*```(\S*)")
MARK = re.compile(r"^\s*<!--\s*([a-z-]+):\s*(.*?)\s*-->\s*$")
KINDS = {"not-run", "run-by", "docs-inputs", "docs-file"}
COMMAND = re.compile(r"^(\$ )?openral-data(\s|$)")


@dataclass(frozen=True)
class Block:
    page: str
    line: int  # of the opening fence, 1-based
    lang: str
    lines: tuple[str, ...]
    marks: dict[str, str] = field(default_factory=dict)

    @property
    def where(self) -> str:
        return f"{self.page}:{self.line}"

    @property
    def is_example(self) -> bool:
        return self.lang in SHELL or any(COMMAND.match(line.strip()) for line in self.lines)


@dataclass(frozen=True)
class Step:
    argv: list[str]
    shown: list[str]  # the output lines a transcript shows after the command
    stdout_to: str | None


def blocks(page: str) -> tuple[list[Block], list[int]]:
    """The page's fenced blocks with the markers right above each, and the lines of markers above no block."""
    text = (REPO / page).read_text().splitlines()
    found: list[Block] = []
    stray: list[int] = []
    marks: dict[str, str] = {}
    mark_lines: list[int] = []
    i = 0
    while i < len(text):
        mark = MARK.match(text[i])
        fence = FENCE.match(text[i])
        if mark and mark.group(1) in KINDS:
            marks[mark.group(1)] = mark.group(2)
            mark_lines.append(i + 1)
        elif text[i].lstrip().startswith("<!--"):
            pass  # another tool's marker (e.g. the begin of a block a test reads): ours may stand above it
        elif fence:
            end = next(j for j in range(i + 1, len(text)) if text[j].strip() == "```")
            found.append(Block(page, i + 1, fence.group(1), tuple(text[i + 1 : end]), marks))
            marks, mark_lines, i = {}, [], end
        elif mark_lines:
            stray += mark_lines
            marks, mark_lines = {}, []
        i += 1
    return found, stray + mark_lines


def _joined(lines: tuple[str, ...]) -> list[str]:
    """Lines with `\\` continuations joined."""
    out: list[str] = []
    pending = ""
    for line in lines:
        if line.rstrip().endswith("\\"):
            pending += line.rstrip()[:-1] + " "
            continue
        out.append(pending + line)
        pending = ""
    return out


def steps(block: Block) -> list[Step]:
    """The block's openral-data commands, each with the output a transcript shows after it."""
    lines = _joined(block.lines)
    transcript = any(line.startswith("$ ") for line in lines)
    out: list[Step] = []
    current: Step | None = None
    for line in lines:
        is_command = line.startswith("$ ") if transcript else bool(line.strip()) and not line.startswith("#")
        if not is_command:
            if current is not None and transcript:
                current.shown.append(line)
            continue
        current = None
        if not COMMAND.match(line.strip()):
            continue  # another program's line (jq, cp, ...): not run
        words = shlex.split(line.removeprefix("$ "), comments=True)[1:]
        stdout_to = None
        if "|" in words:
            words = words[: words.index("|")]
        if ">" in words:
            at = words.index(">")
            words, stdout_to = words[:at], words[at + 1]
        current = Step(words, [], stdout_to)
        out.append(current)
    return out


def _same(line: str) -> str:
    return " ".join(line.split())


def run_step(step: Step, where: str, home: Path) -> str | None:
    """Run one command: what is wrong with its outcome, or None. `home` (the page's folder, also the home of
    lerobot's cache) prints as `~`."""
    raw = run_inproc(*(str(home) + word[1:] if word.startswith("~/") else word for word in step.argv))
    run = Run(raw.returncode, raw.stdout.replace(str(home), "~"), raw.stderr.replace(str(home), "~"))
    said = f"{where}: openral-data {shlex.join(step.argv)}\nexit {run.returncode}\n{run.stdout}{run.stderr}"
    shown = [line for line in step.shown if line.strip()]
    if shown and shown[0].startswith("error:"):
        printed = [_same(line) for line in run.stderr.splitlines()]
        return None if run.returncode == 2 and _same(shown[0]) in printed else said
    if run.returncode != 0:
        return said
    printed = [_same(line) for line in run.stdout.splitlines()]
    missing = [line for line in shown if "…" not in line and "..." not in line and _same(line) not in printed]
    if missing:
        return f"{said}not printed: {missing}"
    if step.stdout_to is not None:
        Path(step.stdout_to).write_text(run.stdout)
    return None


def _lerobot_written(root: Path) -> None:
    from tests.support.lerobot_written import write_lerobot_dataset

    write_lerobot_dataset(root, with_success=True, image_camera=True)


def _edit_info(root: Path, edit: Callable[[dict[str, Any]], None]) -> None:
    info_file = root / "meta" / "info.json"
    info = json.loads(info_file.read_text())
    edit(info)
    info_file.write_text(json.dumps(info, indent=4))


def _zeroed_stats(root: Path) -> None:
    _lerobot_written(root)
    stats_file = root / "meta" / "stats.json"
    stats = json.loads(stats_file.read_text())
    zero = re.compile(r"-?\d+(\.\d+)?(e-?\d+)?")
    stats_file.write_text(json.dumps({k: json.loads(zero.sub("0", json.dumps(v))) for k, v in stats.items()}))


def _camera_front(root: Path) -> None:
    _lerobot_written(root.with_name(root.name + ".src"))
    run = run_inproc(
        "features",
        "rename",
        str(root.with_name(root.name + ".src")),
        "--from",
        "observation.images.cam",
        "--to",
        "observation.images.front",
        "--out",
        str(root),
    )
    assert run.returncode == 0, run.stderr


def _at_20_fps(root: Path) -> None:
    _lerobot_written(root)
    _edit_info(root, lambda info: info.update(fps=20))


def _state_abc(root: Path) -> None:
    _lerobot_written(root)
    _edit_info(root, lambda info: info["features"]["observation.state"].update(names=["a", "b", "c"]))


def _pusht_without_videos(root: Path) -> None:
    from tests.support.pusht_like import write_pusht_like

    write_pusht_like(root)
    shutil.rmtree(root / "videos")  # as `hf download REPO --include 'meta/*' 'data/*'` leaves it


def _arm_gripper(root: Path, widening: bool = False) -> None:
    from tests.support import layout_bags as lb

    lb.write_ros2(root, lb.split(gripper_cmd_width=lambda k: 2 if widening and k >= 5 else 1))


def _franka(root: Path) -> None:
    from tests.support import layout_bags as lb

    lb.write_ros1(root, lb.franka())


def _hdf5(root: Path, layout: str) -> None:
    from tests.support import hdf5_layouts

    if layout == "aloha":
        hdf5_layouts.write_aloha(root)
    else:
        hdf5_layouts.write_robomimic(root, layout=layout)


def _zarr(root: Path, umi: bool) -> None:
    from tests.support import replay_buffer as rb

    if umi:  # UMI's own key set (no action: convert derives it as UMI does), JPEG-XL frames, in a zip store
        rb.write_umi_buffer(root, rb.umi_episodes())
    else:
        episodes = [{**e, "img": e["img"].repeat(6, axis=1).repeat(6, axis=2)} for e in rb.sample_episodes()]  # 48x36
        rb.write_replay_buffer(root, episodes)


def _bag(root: Path, depth: bool) -> None:
    from tests.support import bags

    _ = bags.write_ros2(root, "mcap", depth=True) if depth else bags.write_ros1(root)


def _rlds(root: Path, smooth: bool) -> None:
    from tests.support.rlds_written import write_rlds

    write_rlds(root, smooth=smooth)


def _offline(root: Path, kind: str) -> None:
    from tests.support import offline_sources

    if kind == "d4rl":
        offline_sources.write_d4rl(root)
    elif kind == "maniskill":
        offline_sources.write_maniskill(root)
    else:  # minari writes <MINARI_DATASETS_PATH>/<dataset id>: written beside, then moved to `root`
        shutil.move(offline_sources.write_minari(root.parent / ".minari"), root)
        shutil.rmtree(root.parent / ".minari")


def _mock_pick(root: Path, episodes: str) -> None:
    run = run_inproc("record", "--scene", "mock_pick", "--n-episodes", episodes, "--out", str(root))
    assert run.returncode == 0, run.stderr


INPUTS: dict[str, Callable[[Path], None]] = {
    # three episodes (6, 9, 4 frames, 10 fps) lerobot 0.6.1 wrote: a video camera `cam`, a dtype: image camera
    # `wrist`, state names x, y, z (tests/support/lerobot_written.py)
    "lerobot-written": _lerobot_written,
    "lerobot-written-zeroed-stats": _zeroed_stats,  # ... its meta/stats.json all zeros
    "lerobot-written-cam-as-front": _camera_front,  # ... its camera renamed observation.images.front
    "lerobot-written-20-fps": _at_20_fps,  # ... its info.json saying 20 fps
    "lerobot-written-state-abc": _state_abc,  # ... its state names a, b, c
    # bags of tests/support/layout_bags.py: franka_ros's /joint_states at 100 Hz (ROS 1); arm and gripper on
    # topics of their own (ROS 2, MCAP storage), the gripper's command from 2 numbers wide after 5 messages
    "franka-ros1-bag": _franka,
    "arm-gripper-ros2-bag": _arm_gripper,
    "arm-gripper-widening-ros2-bag": lambda root: _arm_gripper(root, widening=True),
    # tests/support/bags.py's bag: joint states, a command, a camera (ROS 1); with RealSense-like depth (ROS 2)
    "robot-ros1-bag": lambda root: _bag(root, depth=False),
    "realsense-ros2-bag": lambda root: _bag(root, depth=True),
    # array sources: tests/support/hdf5_layouts.py, replay_buffer.py (zarr), rlds_written.py (a TFDS folder)
    "robomimic-hdf5": lambda root: _hdf5(root, "robomimic"),
    "libero-hdf5": lambda root: _hdf5(root, "libero"),
    "mimicgen-hdf5": lambda root: _hdf5(root, "mimicgen"),
    "aloha-folder": lambda root: _hdf5(root, "aloha"),
    "replay-buffer-zarr": lambda root: _zarr(root, umi=False),  # pictures 48x36
    "umi-zarr-zip": lambda root: _zarr(root, umi=True),
    "rlds-folder": lambda root: _rlds(root, smooth=False),  # 12x16 JPEG pictures
    "rlds-folder-64px": lambda root: _rlds(root, smooth=True),  # 64x64 ones (av1 needs 32x32 at least)
    # tests/support/offline_sources.py: a D4RL flat file, a Minari dataset minari wrote, a ManiSkill .h5 + .json
    "d4rl-hdf5": lambda root: _offline(root, "d4rl"),
    "minari-dataset": lambda root: _offline(root, "minari"),
    "maniskill-h5": lambda root: _offline(root, "maniskill"),
    # lerobot/pusht's shape (tests/support/pusht_like.py), downloaded without its videos
    "pusht-without-videos": _pusht_without_videos,
}
RECORDED = re.compile(r"mock-pick-(\d+)")  # openral-data record --scene mock_pick --n-episodes N


def maker(name: str) -> Callable[[Path], None] | None:
    recorded = RECORDED.fullmatch(name)
    return (lambda root: _mock_pick(root, recorded.group(1))) if recorded else INPUTS.get(name)


def make_inputs(spec: str, home: Path) -> None:
    for item in spec.split(","):
        path, _, name = (part.strip() for part in item.partition("="))
        target = Path(path.replace("~", str(home), 1))
        shutil.rmtree(target, ignore_errors=True)
        target.parent.mkdir(parents=True, exist_ok=True)
        make = maker(name)
        assert make is not None, name
        make(target)


def runnable(page: str) -> list[Block]:
    return [b for b in blocks(page)[0] if b.is_example and not ({"not-run", "run-by"} & b.marks.keys())]


def test_every_example_is_run_or_marked_with_a_reason() -> None:
    problems: list[str] = []
    for page in PAGES:
        found, stray = blocks(page)
        problems += [f"{page}:{n}: a marker above no block" for n in stray]
        for block in found:
            if block.marks.keys() - {"docs-file"} and not block.is_example:
                problems.append(f"{block.where}: a marker on a block that is no shell example")
            for kind, value in block.marks.items():
                if not value:
                    problems.append(f"{block.where}: {kind}: says nothing")
            if "run-by" in block.marks and not (REPO / block.marks["run-by"]).is_file():
                problems.append(f"{block.where}: run-by: no such test {block.marks['run-by']}")
            for item in block.marks.get("docs-inputs", "").split(",") if "docs-inputs" in block.marks else []:
                if maker(item.partition("=")[2].strip()) is None:
                    problems.append(f"{block.where}: docs-inputs: unknown maker in {item.strip()!r}")
            if block.is_example and not ({"not-run", "run-by"} & block.marks.keys()) and not steps(block):
                problems.append(f"{block.where}: no openral-data command to run; mark it <!-- not-run: why -->")
    assert not problems, "\n".join(problems)


@pytest.mark.slow  # records (mock and MuJoCo scenes) and edits, as the pages do
@pytest.mark.parametrize("page", [p for p in PAGES if runnable(p)])
def test_the_examples_of(page: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("OPENRAL_DATA_HOME", str(tmp_path))
    monkeypatch.setenv("COLUMNS", "100")
    monkeypatch.setenv("HF_LEROBOT_HOME", str(tmp_path / ".cache" / "huggingface" / "lerobot"))
    wrong: list[str] = []
    for block in blocks(page)[0]:
        if "docs-file" in block.marks:
            Path(block.marks["docs-file"]).write_text("".join(line + "\n" for line in block.lines))
        if block not in runnable(page):
            continue
        if "docs-inputs" in block.marks:
            make_inputs(block.marks["docs-inputs"], tmp_path)
        wrong += [w for step in steps(block) if (w := run_step(step, block.where, tmp_path)) is not None]
    assert not wrong, "\n\n".join(wrong)


def _synopses() -> list[tuple[str, list[str], set[str]]]:
    """Each synopsis line (with its continuation lines) of a block marked `not-run: synopsis`: where, the command
    words, the flags it names (those before a `COMMAND` placeholder: after it they are another command's)."""
    out: list[tuple[str, list[str], set[str]]] = []
    for page in PAGES:
        for block in blocks(page)[0]:
            if not block.marks.get("not-run", "").startswith("synopsis"):
                continue
            entries: list[str] = []
            for line in block.lines:
                if line.startswith("openral-data"):
                    entries.append(line)
                elif entries:
                    entries[-1] += " " + line
            for entry in entries:
                code = entry.split("#")[0].split(" COMMAND")[0]
                words = code.split()[1:]
                command = list(itertools.takewhile(lambda w: re.fullmatch(r"[a-z][a-z0-9-]*", w), words))
                flags = set(re.findall(r"(?<![\w-])(--[a-z][a-z0-9-]*|-[a-z]{1,2})\b", code))
                out.append((block.where, command, flags))
    return out


def test_synopses_name_only_flags_their_command_takes(monkeypatch: pytest.MonkeyPatch) -> None:
    """A synopsis is not run, but every flag it shows must be in that command's `--help`."""
    monkeypatch.setenv("COLUMNS", "200")
    helps: dict[tuple[str, ...], str] = {}
    wrong: list[str] = []
    for where, command, flags in _synopses():
        if tuple(command) not in helps:
            run = run_inproc(*command, "--help")
            assert run.returncode == 0, (where, command, run.stderr)
            helps[tuple(command)] = run.stdout
        missing = sorted(f for f in flags if f not in helps[tuple(command)])
        wrong += [f"{where}: openral-data {' '.join(command)}: {missing}"] if missing else []
    assert not wrong, "\n".join(wrong)
