"""lerobot 0.6.1's hardware classes behind the HAL, for any robot, camera and teleoperator it registers.

A manifest's `hardware:` block names lerobot types and their configs (schemas/hal.py); this module builds them
with lerobot's own registries and factories (`RobotConfig.get_choice_class(type)(**fields)`,
`make_robot_from_config`, `make_cameras_from_configs`, `make_teleoperator_from_config`): no per-robot code.
Joint values are read and written through the lerobot feature keys of the manifest's state/action names
(`<name>` or `<name>.pos`). What stays ours: the fixed-rate loop, stamps, staleness, safety filter, e-stop.

Unattended recording never starts lerobot's interactive calibration: a device with a motor bus (each arm of a
bimanual one) needs its calibration file (`lerobot-calibrate` writes it) and motors that agree with it, else
connecting fails with one line. A config's nested dataclass fields (a bimanual robot's `left_arm_config: {port:
...}`) are built from the manifest's mappings, as lerobot's own CLI parser builds them. Cameras are not given
to the robot's config (lerobot would read them inside `get_observation`): each
runs in its own capture thread with its own stamps (`sensors.ThreadedCamera`).
"""

from __future__ import annotations

import dataclasses
import importlib
import pkgutil
import typing
from functools import cache
from pathlib import Path
from typing import Any

import numpy as np

from openral_data.errors import ConfigError, HalError, install_hint
from openral_data.producers.hal.cameras import realsense
from openral_data.producers.hal.cameras.sensors import CameraSensor, LerobotCamera
from openral_data.producers.hal.robots.base import HalBase, JointCommand, RobotState, monotonic
from openral_data.schemas.hal import HardwareConfig, LerobotDevice
from openral_data.schemas.robot import RobotManifest
from openral_data.types import CameraShape

# A motor-bus read waits for its reply in `select` at most this long per try (waiting_bus_reads)
BUS_READ_WAIT_S = 0.005
KINDS = {"robots": "RobotConfig", "teleoperators": "TeleoperatorConfig", "cameras": "CameraConfig"}
CONNECT_ERRORS = (OSError, ConnectionError, RuntimeError, TimeoutError)


@cache
def registry(kind: str) -> Any:
    """lerobot's config base class of `kind`, with every config module of its sub-packages imported (they
    register their types; they are plain dataclasses, no device SDK is imported)."""
    try:
        package = importlib.import_module(f"lerobot.{kind}")
    except ImportError as exc:
        if (exc.name or "").split(".")[0] == "lerobot":  # lerobot itself is an extra
            raise ConfigError(
                f"hardware: lerobot devices need the 'lerobot' extra: {install_hint('lerobot')}"
            ) from None
        raise ConfigError(f"hardware: lerobot.{kind} cannot be imported: {exc}") from None
    for sub in pkgutil.iter_modules(package.__path__):
        if not sub.ispkg:
            continue
        for mod in pkgutil.iter_modules([str(Path(package.__path__[0]) / sub.name)]):
            if mod.name.startswith("config"):
                try:
                    importlib.import_module(f"lerobot.{kind}.{sub.name}.{mod.name}")
                except ImportError:  # an optional SDK the config itself needs: that type stays unknown
                    continue
    return getattr(package, KINDS[kind])


# (our extra, the SDK's module, what it is): the motor-bus SDKs our extras of the same name install
OUR_BUS_EXTRAS = (
    ("feetech", "scservo_sdk", "lerobot's Feetech driver"),
    ("dynamixel", "dynamixel_sdk", "lerobot's Dynamixel driver"),
)


def missing_sdk(exc: ImportError) -> str:
    """What a lerobot device whose SDK is missing needs: our extra of the same name for the Feetech and the
    Dynamixel bus (lerobot's own message names its `lerobot[feetech]` / `lerobot[dynamixel]` extra), else
    lerobot's words."""
    for extra, module, what in OUR_BUS_EXTRAS:
        if f"lerobot[{extra}]" in str(exc) or exc.name == module:
            return f"needs the '{extra}' extra ({what}): {install_hint(extra)}"
    return f"needs its lerobot extra: {exc}"


def lerobot_config(kind: str, spec: LerobotDevice, source: str, field: str) -> Any:
    """lerobot's config object of `spec["type"]` (a `calibration_dir` relative to the manifest `source`)."""
    base = registry(kind)
    name = spec["type"]
    known = base.get_known_choices()
    if name not in known:
        raise ConfigError(f"{source}: {field}.type: {name!r} is not a lerobot {kind} type; valid: {', '.join(known)}")
    fields = {k: v for k, v in spec.items() if k != "type" and v is not None}
    if "calibration_dir" in fields:
        cal = Path(str(fields["calibration_dir"])).expanduser()
        fields["calibration_dir"] = cal if cal.is_absolute() else Path(source).parent / cal
    try:
        return with_nested(known[name], fields)
    except (TypeError, ValueError) as exc:
        raise ConfigError(f"{source}: {field}: {exc}") from None


def with_nested(cls: Any, fields: dict[str, Any]) -> Any:
    """`cls(**fields)`, a mapping given for a dataclass-typed field built into that dataclass first (lerobot's
    bimanual configs: `left_arm_config: {port: ...}`, as lerobot's CLI parser builds them)."""
    if not any(isinstance(v, dict) for v in fields.values()):
        return cls(**fields)
    try:
        hints = typing.get_type_hints(cls)
    except NameError:  # an annotation lerobot's module cannot resolve: leave the mappings to lerobot
        hints = {}
    nested = {
        k: with_nested(hints[k], v) if isinstance(v, dict) and dataclasses.is_dataclass(hints.get(k)) else v
        for k, v in fields.items()
    }
    return cls(**nested)


def connect_device(device: Any, source: str, field: str, type_name: str) -> None:
    """`device.connect(calibrate=False)` with the calibration rules above (for each arm of a bimanual device);
    one line per failure."""
    arms = motor_arms(device)
    for path in [getattr(arm, "calibration_fpath", None) for arm in arms]:
        if path is not None and not Path(path).is_file():
            raise ConfigError(
                f"{source}: {field}.calibration_dir: no calibration {path} (run: lerobot-calibrate "
                f"--{'teleop' if 'teleop' in field else 'robot'}.type={type_name} --...port=... --...id={device.id})"
            )
    port = getattr(device.config, "port", None)
    try:
        device.connect(calibrate=False)
    except CONNECT_ERRORS as exc:
        raise HalError(f"{source}: {field}.port: cannot connect to {port}: {exc}", code="hal.connect") from None
    if differs := [getattr(arm, "calibration_fpath", None) for arm in arms if not arm.is_calibrated]:
        device.disconnect()
        raise HalError(
            f"{source}: {field}.calibration_dir: the motors' calibration differs from {differs[0]} "
            "(recalibrate with lerobot-calibrate, or point calibration_dir at this arm's file)",
            code="hal.calibration",
        )
    waiting_bus_reads(arms)


def waiting_bus_reads(arms: list[Any]) -> None:
    """Make each motor bus of `arms` wait for its replies instead of polling for them.

    The servo SDKs (scservo, dynamixel_sdk) open the port non-blocking (pyserial `timeout=0`) and poll `read()` in a
    Python loop until a reply is complete or their packet timeout passes: on the control thread, a core spinning for
    the whole bus round trip (milliseconds through a USB adapter) and the GIL taken back thousands of times a read,
    each time behind whichever camera or encoder thread got it meanwhile. With a read timeout of BUS_READ_WAIT_S
    each poll sleeps in `select` (the GIL released) until the bytes it asked for are there; the SDK's own timeout
    check is unchanged (a missing reply is noticed at most BUS_READ_WAIT_S later)."""
    for arm in arms:
        serial_port = getattr(getattr(arm.bus, "port_handler", None), "ser", None)
        if serial_port is not None and serial_port.timeout == 0:
            serial_port.timeout = BUS_READ_WAIT_S


def motor_arms(device: Any) -> list[Any]:
    """The parts of a lerobot device with a motor bus: the device itself, or the arms a
    bimanual device holds (lerobot's bi_so_follower: `left_arm`, `right_arm`)."""
    if getattr(device, "bus", None) is not None:
        return [device]
    return [part for part in vars(device).values() if getattr(part, "bus", None) is not None]


def feature_keys(names: list[str], features: dict[str, Any], source: str, field: str) -> list[str]:
    """The lerobot feature key of each manifest name: the name itself, or `<name>.pos`."""
    keys = []
    for n in names:
        key = n if n in features else f"{n}.pos"
        if key not in features:
            raise ConfigError(
                f"{source}: {field}: {n!r} is none of the lerobot device's features ({', '.join(features)})"
            )
        keys.append(key)
    return keys


def stream_source(spec: LerobotDevice) -> bool:
    """An OpenCV camera reading a video file or a network URL (not a device: an index or /dev/...)."""
    where = spec.get("index_or_path")
    return spec["type"] == "opencv" and isinstance(where, str) and not where.startswith("/dev/")


def make_cameras(hardware: HardwareConfig, source: str) -> dict[str, CameraSensor]:
    """The manifest's cameras, each behind its own capture thread (connected when the HAL connects); a
    RealSense with `use_depth` adds its aligned depth as `<name>_depth` (producers/hal/cameras/realsense.py).

    `width`/`height` are required: the dataset's video size. A file or a URL has its own size and rate, which
    OpenCV cannot set: for those they are not passed to lerobot, and each frame is checked against them."""
    from lerobot.cameras import make_cameras_from_configs

    out: dict[str, CameraSensor] = {}
    for name, spec in hardware.cameras.items():
        field = f"hardware.cameras.{name}"
        width, height = spec.get("width"), spec.get("height")
        if not isinstance(width, int) or not isinstance(height, int) or width < 1 or height < 1:
            raise ConfigError(f"{source}: {field}: width and height are required (the dataset's video size)")
        given = {k: v for k, v in spec.items() if not stream_source(spec) or k not in ("width", "height", "fps")}
        if spec["type"] == realsense.TYPE:
            config = lerobot_config(
                "cameras", {k: v for k, v in given.items() if k not in realsense.OURS}, source, field
            )
            capture = realsense.make_realsense(name, spec, CameraShape(height, width), source, field, config)
            out[name] = capture
            if capture.depth is not None:
                if capture.depth.name in hardware.cameras:
                    raise ConfigError(
                        f"{source}: {field}.use_depth: its depth stream {capture.depth.name!r} is also a camera name"
                    )
                out[capture.depth.name] = capture.depth
            continue
        config = lerobot_config("cameras", given, source, field)
        device = make_cameras_from_configs({name: config})[name]
        out[name] = LerobotCamera(name, CameraShape(height, width), device, source, field)
    return out


class LerobotHal(HalBase):
    """Any `lerobot.robots` robot; the manifest's state/action names pick its joint features."""

    def __init__(self, robot: RobotManifest, hardware: HardwareConfig, source: str, port: str | None = None) -> None:
        super().__init__(robot)
        self.source = source
        self.hardware = hardware
        spec = hardware.robot_config()
        if port is not None:
            spec["port"] = port
        self.type_name = str(spec["type"])
        self.field = "hardware.robot" if hardware.robot is not None else "hardware"
        config = lerobot_config("robots", spec, source, self.field)
        try:
            from lerobot.robots import make_robot_from_config

            self.driver: Any = make_robot_from_config(config)
        except ImportError as exc:  # the device SDK comes with a lerobot extra (feetech, dynamixel, ...)
            raise ConfigError(f"{source}: {self.field}.type: {self.type_name} {missing_sdk(exc)}") from None
        names = robot.observation.state.names or []
        self.state_keys = feature_keys(names, self.driver.observation_features, source, "observation.state.names")
        action_names = robot.action.names or []
        self.action_keys = feature_keys(action_names, self.driver.action_features, source, "action.names")
        self.cameras.update(make_cameras(hardware, source))

    def _connect(self) -> None:
        connect_device(self.driver, self.source, self.field, self.type_name)

    def _disconnect(self) -> None:
        if self.driver.is_connected:
            self.driver.disconnect()

    def _read_state(self) -> RobotState:
        before = monotonic()
        obs = self.driver.get_observation()
        stamp = (before + monotonic()) / 2  # the middle of the bus read
        return RobotState(np.array([obs[k] for k in self.state_keys], dtype=np.float32), stamp)

    def _send(self, command: JointCommand) -> JointCommand:
        goal = {k: float(v) for k, v in zip(self.action_keys, command.positions, strict=True)}
        sent = self.driver.send_action(goal)
        return JointCommand(np.array([sent[k] for k in self.action_keys], dtype=np.float32))

    def begin_episode(self, seed: int) -> dict[str, Any]:
        port = getattr(self.driver.config, "port", None)
        return {"hal": f"lerobot:{self.type_name}", "robot": self.robot.name, "port": port}


def make_hardware_hal(robot: RobotManifest, source: str, port: str | None = None) -> HalBase:
    if robot.hardware is None:
        raise ConfigError(f"{source}: hardware: robot {robot.name!r} has no hardware block (--mode real needs one)")
    return LerobotHal(robot, robot.hardware, source, port)
