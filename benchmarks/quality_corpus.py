"""The labelled corpus of `calibrate_quality.py`: clean episodes of several kinds of data, and the same episodes
with one known fault each (`tests/support/data_faults.py`), every dataset cached under one folder.

Clean sources (`CORPUS/clean/NAME`, made once, reused while present):

* **expert**: our scripted experts, `openral-data record --scene S` on every scene whose default rSkill is a
  scripted expert (the tabletop scenes' scripted pick/place/push/drawer/stack, Meta-World's expert policies),
  and joint sweeps of the UR5e and Jaco twins (`record --hal R --mode sim`, joint angles in radians);
* **generated**: `openral-data generate` (MimicGen-style) from the tabletop_pick_place experts;
* **person**: gamepad teleop sessions of tabletop_push driven by a scripted person through the real device path
  (`teleop_sessions.py`), and the third-party LeRobot recordings of people teleoperating real robots in
  `../shared/fixtures/lerobot/` (v2.1 ones upgraded with `openral-data upgrade`).

Each clean episode is a *unit* (foreign episodes cut to their first `--max-frames` frames, pictures subsampled to
at most `--max-side` pixels). Per source, the units are rewritten through our writer (`work/NAME/clean`), and
once per fault kind with that fault injected into every unit (`work/NAME/KIND`, the truths in `truths.json`); a
fault judged against the other episodes (`ONE_PER_DATASET`) is written once per unit, among the clean others
(`work/NAME/KIND/uU`).
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from teleop_sessions import record_sessions  # noqa: E402

from openral_data.formats.lerobot_v3.reader import read_episodes  # noqa: E402
from tests.support import data_faults as df  # noqa: E402

EXPERT_SCENES = (  # every scene whose default rSkill is a scripted expert (`openral-data list scenes`)
    "tabletop_pick_place",
    "tabletop_pick_place_randomized",
    "tabletop_open_drawer",
    "tabletop_pick_clutter",
    "tabletop_place_on",
    "tabletop_push",
    "tabletop_stack",
    "metaworld_button_press_topdown",
    "metaworld_door_open",
    "metaworld_drawer_open",
    "metaworld_pick_place",
    "metaworld_push",
    "metaworld_window_open",
)
FIXTURES = REPO.parent / "shared" / "fixtures" / "lerobot"
TELEOP_MORE = 8  # the second set of gamepad sessions (people's data is the scarcest in the corpus)


@dataclass(frozen=True)
class Source:
    name: str
    data: str  # expert, generated or person
    root: Path


# `python -c VIRTUAL_CLOCK ARGS`: `openral-data ARGS` on a clock of its own. The main thread's `time.sleep(d)`
# moves `time.monotonic()` on by d and takes no time; work takes none either. A twin recorded so (`record --hal R
# --mode sim`: its physics steps up to the monotonic clock, its cameras are polled) meets every tick's deadline
# however loaded the machine is: no overrun, no missed tick (a missed tick is a hidden frame drop, the physics having
# run on). Other threads sleep for real (the encoders' waits).
VIRTUAL_CLOCK = """
import threading, time
real_sleep, now = time.sleep, [time.monotonic()]
def sleep(d):
    if threading.current_thread() is threading.main_thread():
        now[0] += max(0.0, d)
    else:
        real_sleep(d)
time.monotonic, time.sleep = (lambda: now[0]), sleep
import sys
sys.argv[0] = "openral-data"
from openral_data.cli import main
main()
"""


def cli(*args: str, virtual_clock: bool = False) -> None:
    """`openral-data ARGS` in a subprocess (MuJoCo rendering off screen; `VIRTUAL_CLOCK`'s clock when asked); its
    output only when it fails."""
    env = {**os.environ, "MUJOCO_GL": "egl", "PYTHONPATH": str(REPO)}
    run = ["-c", VIRTUAL_CLOCK] if virtual_clock else ["-m", "openral_data.cli"]
    done = subprocess.run([sys.executable, *run, *args], check=False, capture_output=True, text=True, env=env)
    if done.returncode != 0:
        raise RuntimeError(f"openral-data {' '.join(args)}: {done.stderr[-2000:]}")


def ready(root: Path) -> bool:
    return (root / "meta" / "info.json").is_file()


def expert_sources(corpus: Path, scenes: tuple[str, ...], episodes: int) -> list[Source]:
    out = []
    for scene in scenes:
        root = corpus / "clean" / f"expert_{scene}"
        if not ready(root):
            print(f"recording {episodes} expert episodes of {scene}", flush=True)
            cli("record", "--scene", scene, "--n-episodes", str(episodes), "--seed", "100", "--out", str(root),
                "--codec", "h264")  # fmt: skip
        out.append(Source(f"expert_{scene}", "expert", root))
    return out


# joint-space scripted data (`record --hal ROBOT --mode sim`, the `sweep` policy, an rSkill written here per
# episode); twins whose home posture has several joints at 0 (SO-101, OpenArm, Panda) are left out: `sweep`
# commands those joints alike, frame for frame (a `duplicated` action, truly)
HAL_SWEEPS = ("ur5e", "jaco")


def sweep_rskill(folder: Path, robot: str, k: int = 0) -> str:
    """`folder/sweep-ROBOT-K/rskill.yaml`: the `sweep` policy on `robot`'s state and action (its manifest's names),
    its period 4 s + 0.25 s a K (episodes that start at home on a clock of their own would else be the same
    episode, frame for frame); its id."""
    from openral_data.runtime import registry

    names = registry.ROBOTS[robot].observation.state.names or []
    contract = {"dim": len(names), "names": names, "representation": "joint_positions_gripper"}
    manifest = {
        "id": f"sweep-{robot}-{k}", "description": f"sweep the {robot} joints around their start posture",
        "policy": "sweep", "embodiment_tags": [robot], "state_contract": contract, "action_contract": contract,
        "required_cameras": [], "policy_extras": {"amplitude": 0.3, "period": 4.0 + 0.25 * k},
    }  # fmt: skip
    (folder / f"sweep-{robot}-{k}").mkdir(parents=True, exist_ok=True)
    (folder / f"sweep-{robot}-{k}" / "rskill.yaml").write_text(json.dumps(manifest))  # JSON is YAML
    return str(manifest["id"])


def refuse_missed_ticks(root: Path) -> None:
    """Raise (the recording moved aside) when an episode of the HAL recording `root` missed or overran a tick (its
    loop's report in meta/episodes): rows that jump over lost ticks, timestamps even, are no clean episode."""
    late = {}
    for row in read_episodes(root).to_pylist():
        info = row.get("openral.episode_info")
        hal = (json.loads(info) if isinstance(info, str) else info or {}).get("hal", {})
        if hal.get("missed_ticks", 0) or hal.get("overruns", 0):
            late[row["episode_index"]] = (hal.get("missed_ticks"), hal.get("overruns"))
    if late:
        shutil.rmtree(root.with_name(root.name + ".refused"), ignore_errors=True)
        root.rename(root.with_name(root.name + ".refused"))
        raise RuntimeError(f"{root}: episodes missed ticks (missed, overruns): {late}")


def hal_sources(corpus: Path, episodes: int, max_steps: int = 150) -> list[Source]:
    """Scripted joint sweeps of robots' MuJoCo twins: states that are joint angles, named as the robot
    manifest's revolute joints (what the angle checks and the joint limits read). Each episode recorded by a process
    of its own, so that it starts with the twin at home (the twin keeps the posture an episode ended in, and the
    sweep's first command, home, snapped the arm there in one tick: a jump at frame 1). Recorded on `VIRTUAL_CLOCK`'s
    clock (every tick on time, each episode's report checked: `refuse_missed_ticks`): on the real clock the loaded
    2-core machine missed ticks (4-271 an episode at 10 fps), and a missed tick is a hidden frame drop in a
    "clean" episode."""
    out = []
    for robot in HAL_SWEEPS:
        root = corpus / "clean" / f"expert_hal_{robot}_sweep"
        if not ready(root):
            print(f"recording {episodes} sweep episodes of the {robot} twin", flush=True)
            for k in range(1, episodes + 1):  # one process an episode: each starts with the twin at home (`--resume`)
                rskill = sweep_rskill(corpus / "rskills", robot, k - 1)
                cli("record", "--rskills-dir", str(corpus / "rskills"), "--hal", robot, "--mode", "sim", "--rskill",
                    rskill, "--n-episodes", str(k), "--max-steps", str(max_steps), "--seed", "100", "--out", str(root),
                    "--codec", "h264", "--fps", "10", *(["--resume"] if k > 1 else []), virtual_clock=True)  # fmt: skip
            refuse_missed_ticks(root)
        out.append(Source(f"expert_hal_{robot}_sweep", "expert", root))
    return out


def generated_source(corpus: Path, attempts: int) -> list[Source]:
    root, seeds = corpus / "clean" / "generated_tabletop_pick_place", corpus / "clean" / "expert_tabletop_pick_place"
    if not ready(root) and ready(seeds):
        print(f"generating {attempts} attempts from {seeds.name}", flush=True)
        cli("generate", str(seeds), "--scene", "tabletop_pick_place", "--n", str(attempts), "--out", str(root),
            "--codec", "h264")  # fmt: skip
    return [Source("generated_tabletop_pick_place", "generated", root)] if ready(root) else []


def teleop_source(corpus: Path, episodes: int, max_steps: int = 150) -> list[Source]:
    """Gamepad sessions of a scripted person through the real device path (`teleop_sessions.py`): a first set
    (seeds from 0) and a second one on other cubes (`TELEOP_MORE` sessions from seed 100)."""
    out = []
    for name, count, first in (("person_teleop_gamepad", episodes, 0), ("person_teleop_gamepad_b", TELEOP_MORE, 100)):
        root = corpus / "clean" / name
        if not ready(root):
            print(f"recording {count} gamepad teleop sessions from seed {first}", flush=True)
            record_sessions(root, count, max_steps, corpus / "scratch", first)
        out.append(Source(name, "person", root))
    return out


def person_sources(corpus: Path) -> list[Source]:
    out = []
    for fixture in sorted(FIXTURES.glob("*")) if FIXTURES.is_dir() else []:
        info = json.loads((fixture / "meta" / "info.json").read_text())
        root = fixture
        if str(info.get("codebase_version", "")).startswith("v2"):
            root = corpus / "clean" / f"person_{fixture.name}"
            if not ready(root):
                print(f"upgrading {fixture.name}", flush=True)
                cli("upgrade", str(fixture), str(root))
        out.append(Source(f"person_{fixture.name}", "person", root))
    return out


# Faults judged against the dataset's other episodes (`camera_flipped`: an episode's picture against the others'
# median): each unit is written with the fault among the source's other units, clean (`work/SRC/KIND/uU`), as a
# camera turned in one session of a dataset is; a dataset turned in every episode has no right way up to compare
# with (nor would any reference-free check), nor has a dataset of one or two episodes.
ONE_PER_DATASET = ("upside_down",)
MIN_EPISODES = 3  # ... in a source of at least so many episodes (`metrics.quality.views.MIN_EPISODES`)


@dataclass(frozen=True)
class Unit:
    source: str
    data: str
    episode: int  # in the source
    index: int  # in work/SOURCE/*: the written episode
    half: str  # tuning or held-out


def source_units(
    src: Source, max_frames: int, max_side: int, counter: dict[str, int]
) -> tuple[list[df.Clean], list[Unit]]:
    """`src`'s episodes as clean units; units alternate between the halves in order, per kind of data."""
    cleans, units = [], []
    for e in sorted(int(r["episode_index"]) for r in read_episodes(src.root).to_pylist()):
        clean = df.load(src.root, e, max_side=max_side, max_frames=max_frames)
        if clean.n < 20:
            continue
        k = counter.get(src.data, 0)
        counter[src.data] = k + 1
        units.append(Unit(src.name, src.data, e, len(cleans), "tuning" if k % 2 == 0 else "held-out"))
        cleans.append(clean)
    return cleans, units


def built(out: Path, kind: str) -> bool:
    """Whether `out` (`work/SRC/KIND`) holds a finished build of `kind` in the current layout: a
    `ONE_PER_DATASET` kind built in the old one (every unit faulty in one dataset, truths without `dataset`)
    is stale, and made again."""
    if not (out / "truths.json").is_file():
        return False
    return kind not in ONE_PER_DATASET or all("dataset" in t for t in json.loads((out / "truths.json").read_text()))


def build(src: Source, work: Path, kinds: tuple[str, ...], cleans: list[df.Clean]) -> None:
    """`work/SRC/clean` and one `work/SRC/KIND` per fault kind (each unit with that fault; units where it does
    not apply are left out, `truths.json` maps written episodes to units)."""
    base = work / src.name
    if not ready(base / "clean"):
        shutil.rmtree(base / "clean", ignore_errors=True)
        df.write(base / "clean", cleans)
    for kind in kinds:
        out = base / kind
        if built(out, kind):
            continue
        shutil.rmtree(out, ignore_errors=True)  # a build cut short: made again
        faulty, truths = [], []
        for u, clean in enumerate(cleans):
            try:
                ep, truth = df.inject(clean, kind, seed=1000 * u + df.KINDS.index(kind))
            except df.NotApplicable:
                continue
            if kind in ONE_PER_DATASET:  # the unit faulty among the source's other units, clean
                if len(cleans) < MIN_EPISODES:
                    continue
                df.write(out / f"u{u}", [ep if k == u else c for k, c in enumerate(cleans)])
                truths.append({"dataset": f"u{u}", "episode": u, "unit": u, **df.labelled(truth, ep)})
                continue
            truths.append({"episode": len(faulty), "unit": u, **df.labelled(truth, ep)})
            faulty.append(ep)
        if faulty:
            df.write(out, faulty)
        out.mkdir(parents=True, exist_ok=True)
        (out / "truths.json").write_text(json.dumps(truths, indent=1))
