"""Who drives a recording is one choice (record/drivers/choice.py): every combination of `--rskill`, `--policy`,
`--teleop` and `--hal` maps to exactly one driver kind, or is refused with the one line `record` has always
given, by the CLI and by `HalRecordOptions` (the Python API) alike."""

from __future__ import annotations

import itertools
from pathlib import Path

import pytest

from openral_data.errors import UsageError
from openral_data.record.drivers.choice import DriverKind, choose_driver
from openral_data.record.drivers.kinds import OPENERS
from openral_data.record.hal import HalRecordOptions
from tests.support.inproc import run_inproc

K = DriverKind
TELEOPS = (
    None,
    "keyboard",
    "expert",
    "leader",
    "gamepad",
    "gamepad=/dev/input/event3",
    "spacemouse",
    "spacemouse=/dev/hidraw1",
)
BAD_TELEOPS = ("joystick", "gamepad=", "keyboard=/dev/tty", "leader=/dev/ttyACM0")
POLICY_AND_LEADER = "--policy: not with --teleop leader (takeover devices: keyboard, gamepad, spacemouse, expert)"
POLICY_AND_TELEOP = "--policy: not with --teleop unless the device takes over (takeover=True: an intervention session)"
LEADER_NEEDS_HAL = "--teleop leader: needs --hal ROBOT_ID (the robot whose manifest names the leader)"
GIVE_ONE = "--policy, --rskill: give one (a lerobot checkpoint, or an rSkill manifest)"


def _bad_teleop(teleop: str) -> str:
    return f"--teleop: {teleop!r}; valid: keyboard, expert, leader, gamepad[=NODE], spacemouse[=NODE]"


def expected(rskill: str | None, policy: str | None, teleop: str | None, hal: bool) -> DriverKind | str:
    """What `record` did before the choice had a home (cli/record.py, record/hal.py): a kind, or the error; and
    since #51 a checkpoint with a takeover device is an intervention session, as an rSkill with one is."""
    if policy is not None and teleop == "leader":
        return POLICY_AND_LEADER
    if teleop == "leader" and not hal:
        return LEADER_NEEDS_HAL
    if teleop in BAD_TELEOPS:
        return _bad_teleop(teleop)
    if policy is not None and rskill is not None:
        return GIVE_ONE
    if teleop == "leader":
        return K.LEADER
    if teleop is not None:  # a device: with a policy to take over from, an intervention session
        return K.TAKEOVER if rskill is not None or policy is not None else K.PERSON
    return K.CHECKPOINT if policy is not None else K.RSKILL


COMBINATIONS = list(itertools.product((None, "scripted-push"), (None, "ckpt"), TELEOPS + BAD_TELEOPS, (False, True)))


@pytest.mark.parametrize(("rskill", "policy", "teleop", "hal"), COMBINATIONS)
def test_every_combination_is_one_kind_or_one_line(
    rskill: str | None, policy: str | None, teleop: str | None, hal: bool
) -> None:
    want = expected(rskill, policy, teleop, hal)
    if not isinstance(want, DriverKind):  # (a kind is a StrEnum: tested first)
        with pytest.raises(UsageError) as err:
            choose_driver(rskill, policy, teleop, hal=hal)
        assert str(err.value) == want
        return
    choice = choose_driver(rskill, policy, teleop, hal=hal)
    assert choice.kind is want and choice.kind in OPENERS  # each kind has the one module that opens it
    node = teleop.partition("=")[2] if teleop is not None else ""
    assert choice.node == (Path(node) if node else None)  # `--teleop gamepad=NODE`: the node, else found
    assert (choice.device is not None) == (want in (K.PERSON, K.TAKEOVER))
    assert choice.terminal == (teleop == "keyboard")  # the keyboard: the operator keys share its terminal
    assert choice.person == (teleop is not None)


def test_the_api_says_whether_a_person_takes_over() -> None:
    """`HalRecordOptions` names the takeover itself: the same choice, never a second one."""
    assert HalRecordOptions(robot="ur5e", rskill="r", teleop="gamepad", takeover=False).driver.kind is K.PERSON
    assert HalRecordOptions(robot="ur5e", rskill="r", teleop="spacemouse", takeover=True).driver.kind is K.TAKEOVER
    assert HalRecordOptions(robot="so101", rskill=None, teleop="leader").driver.kind is K.LEADER
    # the DAgger round (pipeline/dagger_step.py): a checkpoint drives, the scripted expert takes over
    dagger = HalRecordOptions(robot="franka_panda", rskill=None, policy="ckpt", teleop="expert", takeover=True)
    assert dagger.driver.kind is K.TAKEOVER and dagger.driver.device is not None
    with pytest.raises(UsageError, match=r"^--policy: not with --teleop unless"):  # the API says it takes over
        HalRecordOptions(robot="franka_panda", rskill=None, policy="ckpt", teleop="expert")
    with pytest.raises(UsageError, match=r"^interventions: a policy"):
        HalRecordOptions(robot="ur5e", rskill="r", teleop=None, takeover=True)


@pytest.mark.parametrize(
    ("args", "line"),
    [
        (("--policy", "ckpt", "--teleop", "leader"), POLICY_AND_LEADER),
        (("--teleop", "leader"), LEADER_NEEDS_HAL),
        (("--hal", "ur5e", "--teleop", "joystick"), _bad_teleop("joystick")),
        (("--hal", "ur5e", "--teleop", "gamepad="), _bad_teleop("gamepad=")),
        (("--hal", "so101", "--policy", "ckpt", "--rskill", "r"), GIVE_ONE),
        (("--policy", "ckpt", "--rskill", "r"), GIVE_ONE),
        (
            ("--hal", "ur5e", "--teleop", "keyboard", "--operator", "auto"),
            "--teleop keyboard: the operator keys come from the same terminal (--operator keyboard)",
        ),
    ],
)
def test_the_cli_refuses_as_before(project: Path, tmp_path: Path, args: tuple[str, ...], line: str) -> None:
    """The refused combinations through `record`: the one line (exit 2) they always gave, nothing written."""
    out = tmp_path / "out"
    r = run_inproc("record", *args, "--out", str(out))
    assert (r.returncode, r.stderr.splitlines()) == (2, [f"error: {line}"])
    assert not out.exists()
    with pytest.raises(UsageError):  # the same line from the one place the choice is made
        rskill, policy, teleop, hal = _choice_args(args)
        choose_driver(rskill, policy, teleop, hal=hal)


def _choice_args(args: tuple[str, ...]) -> tuple[str | None, str | None, str | None, bool]:
    given = dict(zip(args[::2], args[1::2], strict=True))
    if given.get("--operator") == "auto":  # the operator is not the driver: refused by the HAL's options
        return ("x", "ckpt", "keyboard", True)
    return given.get("--rskill"), given.get("--policy"), given.get("--teleop"), "--hal" in given
