"""RealSense cameras on the robot: lerobot's `RealSenseCamera` (pyrealsense2 2.59) behind the HAL, colour and
aligned depth, tested through the SDK itself.

There is no camera here, so the test makes an SDK recording: an `rs.software_device` with a colour sensor (rgb8)
and a depth sensor (z16, depth scale 1 mm) with their intrinsics and extrinsics, recorded by `rs.recorder` (a
`.db3` rosbag2 file) as frames are pushed at a live camera's pace, with a pause in the middle. The manifest names
the camera by the recording's serial number with `playback:` the file; lerobot's own pipeline opens it
(`rs.config.enable_device_from_file`) and plays it in real time, the SDK's `rs.align` aligns depth to colour,
and the HAL loop records it with the SO-101 follower on a SIMULATED Feetech bus.
"""

from __future__ import annotations

import itertools
import time
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
import pytest
import yaml
from rosbags.highlevel import AnyReader

from openral_data.formats.lerobot_v3.depth import DepthSettings
from openral_data.producers.hal.cameras.sensors import CameraSample
from openral_data.record.hal import HalRecordOptions, record_hal
from tests.producers.test_opencv_camera import H, W, nearest, source_frame
from tests.support.feetech_bus import SimulatedFeetechBus
from tests.support.hal import episode_infos, frames_table
from tests.support.inproc import run_inproc
from tests.support.realsense import SoftwareRealSense, push, record_sdk, slope_mm, software_camera

rs = pytest.importorskip("pyrealsense2")

SERIAL = "123456789"
RATE, N = 15, 68  # frames of W x H (the OpenCV test's source frames), at 15 fps
PRIMING = 3  # framesets the syncer sees before the reference's first
STALL_AT, STALL_S = 20, 0.8  # the recording pauses after frame STALL_AT
FX, FY, CX, CY = 50.0, 51.0, 31.5, 23.5


DEPTH_STEP = 25  # mm: each source depth frame is this much further than the one before


def depth_frame(k: int) -> npt.NDArray[np.uint16]:
    """Depth frame k (millimetres): a slope over the image, DEPTH_STEP further per frame."""
    return slope_mm(W, H, k, DEPTH_STEP)


def nearest_depth(depth: npt.NDArray[Any]) -> int:
    """The source depth frame a depth map in mm is (its median offset from frame 0)."""
    return int(np.rint(np.median(depth.astype(np.float64) - depth_frame(0)) / DEPTH_STEP))


def camera(depth_units: float = 0.001) -> SoftwareRealSense:
    """The software RealSense of these tests: the OpenCV test's source frames and `depth_frame`, W x H at RATE."""
    return SoftwareRealSense(source_frame, depth_frame, W, H, RATE, SERIAL, depth_units, FX, FY, CX, CY)


def record(path: Path, n: int, stall_at: int | None = None, depth_units: float = 0.001) -> Path:
    """An SDK recording of `camera()`: frames 0..n-1 at RATE, pausing STALL_S after frame `stall_at`."""
    return record_sdk(camera(depth_units), path, n, stall_at, STALL_S)


def with_realsense(path: Path, playback: Path, serial: str = SERIAL, **extra: Any) -> None:
    manifest = yaml.safe_load(path.read_text())
    manifest["hardware"]["calibration_dir"] = "calibration"
    manifest["hardware"]["cameras"] = {"wrist": {"type": "intelrealsense", "serial_number_or_name": serial,
        "width": W, "height": H, "fps": RATE, "use_depth": True, "playback": str(playback), **extra}}  # fmt: skip
    path.write_text(yaml.safe_dump(manifest, sort_keys=False))


def aligned_reference(n: int) -> dict[int, npt.NDArray[np.uint16]]:
    """Source depth frame k -> that frame aligned to colour by the SDK's `rs.align`: what an aligned depth camera
    should deliver (the SDK's alignment leaves some pixels without depth, 0, and moves some by a pixel even between
    identical geometries). The source frames go through the SDK's syncer one frameset at a time, after PRIMING
    framesets (the syncer pairs nothing until it has seen both streams: it passes the first colour alone and
    drops its depth), so no frame depends on timing (a pipeline playing the recording, used before, skipped
    frame 0 on a loaded CI machine)."""
    _, streams = software_camera(camera())
    sync, align = rs.syncer(), rs.align(rs.stream.color)
    for sensor, profile, _ in streams:
        sensor.open(profile)
        sensor.start(sync)
    out: dict[int, npt.NDArray[np.uint16]] = {}
    try:
        for number in range(PRIMING + n):
            push(streams, max(number - PRIMING, 0), number, RATE)
            frames = paired(sync, number, timeout_ms=100 if number < PRIMING else 5000)
            assert frames is not None or number < PRIMING, f"no frameset for source frame {number - PRIMING}"
            if frames is not None and number >= PRIMING:
                out[number - PRIMING] = np.asanyarray(align.process(frames).get_depth_frame().get_data()).copy()
    finally:
        for sensor, _, _ in streams:
            sensor.stop()
            sensor.close()
    return out


def paired(sync: Any, number: int, timeout_ms: int) -> Any:
    """The syncer's frameset holding depth and colour of frame `number`, or None when none comes in time."""
    while True:
        ok, frames = sync.try_wait_for_frames(timeout_ms)
        if not ok:
            return None
        depth, colour = frames.get_depth_frame(), frames.get_color_frame()
        if depth and colour and depth.get_frame_number() == number:
            return frames


def one_step_mm(mm: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
    """The spacing (mm) of lerobot's 12-bit depth codes around each depth: one quantization step."""
    settings = DepthSettings()
    codes = settings.quantize(mm.astype(np.float32), "mm").astype(np.int64)
    up = settings.dequantize(np.minimum(codes + 1, 4095)).astype(np.float64)
    down = settings.dequantize(np.maximum(codes - 1, 0)).astype(np.float64)
    mid = settings.dequantize(codes).astype(np.float64)
    return np.maximum(up - mid, mid - down) * 1000.0


@pytest.mark.slow
def test_a_realsense_recording_through_the_hal_loop(so101: tuple[SimulatedFeetechBus, Path], tmp_path: Path) -> None:
    """Colour frames are source frames in order, depth loads in lerobot within one quantization step of the
    source depth (pixels the SDK's alignment left without depth load as depth_min), the pause is counted as stale
    ticks, stamps increase, and both features carry the stream's intrinsics."""
    bus, manifest = so101
    recording = record(tmp_path / "rs.db3", N, stall_at=STALL_AT)
    with_realsense(manifest, recording)
    out = tmp_path / "ds"
    s = record_hal(
        HalRecordOptions(
            robot="so101_follower", rskill="sweep-so-arm", mode="real", port=bus.port, fps=10, max_steps=20,
            out=out, codec="h264", operator="success", formats=("lerobot", "mcap"),
        )
    )  # fmt: skip
    report = s.all_reports[0]
    assert s.episodes[0].length == 20 and report.accounted()
    assert report.stale["wrist"] >= 3 and report.stale["wrist"] == report.stale["wrist_depth"] == report.stale_ticks
    cols = frames_table(out)
    assert sum(cols["openral.ticks_stale"]) == report.stale_ticks
    assert np.all(np.diff(np.array(cols["openral.real_timestamp"])) > 0)
    assert cols["openral.sample_age.wrist"] == cols["openral.sample_age.wrist_depth"]  # one frameset, one stamp
    assert episode_infos(out)[0]["hal"]["stale"]["wrist_depth"] == report.stale["wrist"]
    with AnyReader([out / "mcap" / "episode_000000"]) as bag:  # MCAP: the depth as 16UC1, the intrinsics
        topics = {c.topic: c for c in bag.connections}
        assert topics["/camera/wrist_depth/depth/image_raw"].msgcount == 20
        conn = topics["/camera/wrist_depth/camera_info"]
        info: Any = bag.deserialize(next(bag.messages(connections=[conn]))[2], conn.msgtype)
        assert list(info.k) == pytest.approx([FX, 0, CX, 0, FY, CY, 0, 0, 1])

    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    ds = LeRobotDataset("local/rs", root=out, video_backend="pyav")
    for key, frame_id in (("observation.images.wrist", "wrist"), ("observation.images.wrist_depth", "wrist_depth")):
        info = ds.meta.features[key]["info"]
        assert info["camera_info"]["k"] == pytest.approx([FX, 0, CX, 0, FY, CY, 0, 0, 1])
        assert info["camera_info"]["frame_id"] == frame_id and info["camera_info"]["distortion_model"] == "plumb_bob"
        assert (info["camera_info"]["width"], info["camera_info"]["height"]) == (W, H)
        assert info["intrinsics"]["fx"] == FX
    assert ds.meta.depth_keys == ["observation.images.wrist_depth"]
    reference = aligned_reference(N)
    index, exact = [], 0
    for i in range(len(ds)):
        item = ds[i]
        img = (item["observation.images.wrist"].numpy().transpose(1, 2, 0) * 255).round().astype(np.uint8)
        k, err = nearest(img)
        assert err < 4.0, (i, k, err)
        index.append(k)
        got = item["observation.images.wrist_depth"].numpy()[0].astype(np.float64)  # lerobot: (1, H, W) mm
        kd = nearest_depth(got)  # which source depth frame this is
        assert abs(kd - k) <= 1, (i, k, kd)  # the SDK's frameset pairs colour and depth of the same moment
        want = reference[kd].astype(np.float64)
        hole = want == 0  # no depth after alignment: loads as lerobot's depth_min
        assert (got[hole] == DepthSettings().depth_min * 1000).all(), i
        assert (np.abs(got - want)[~hole] <= one_step_mm(want)[~hole] + 0.5).all(), i
        exact += int((want == depth_frame(kd)).sum())
    assert exact > 0.8 * len(ds) * W * H  # the aligned depth is the source depth but for the SDK's holes and seams
    assert index == sorted(index) and index[-1] - index[0] >= 15


@pytest.fixture(scope="module")
def short_recording(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return record(tmp_path_factory.mktemp("rs") / "short.db3", 20)


def test_a_serial_the_recording_does_not_have_is_one_line_before_episode_0(
    so101: tuple[SimulatedFeetechBus, Path], tmp_path: Path, short_recording: Path
) -> None:
    bus, manifest = so101
    args = ["record", "--hal", "so101_follower", "--mode", "real", "--rskill", "sweep-so-arm", "--port", bus.port]
    with_realsense(manifest, short_recording, serial="987654321")
    r = run_inproc(*args, "--out", str(tmp_path / "a"))
    assert r.returncode == 2 and r.stderr.count("\n") == 1, r.stderr
    assert "hardware.cameras.wrist: cannot open the camera" in r.stderr and "different serial number" in r.stderr
    empty = record(tmp_path / "empty.db3", 0)  # sensors started, no frame ever pushed
    with_realsense(manifest, empty)
    r = run_inproc(*args, "--out", str(tmp_path / "b"))
    assert r.returncode == 2 and r.stderr.count("\n") == 1, r.stderr
    assert "hardware.cameras.wrist: " in r.stderr
    with_realsense(manifest, tmp_path / "absent.db3")
    r = run_inproc(*args, "--out", str(tmp_path / "c"))
    assert r.returncode == 2 and "hardware.cameras.wrist.playback: no recording" in r.stderr, r.stderr
    assert not any((tmp_path / d).exists() for d in "abc")


def test_a_depth_stream_named_like_another_camera_is_one_line(
    so101: tuple[SimulatedFeetechBus, Path], tmp_path: Path, short_recording: Path
) -> None:
    bus, manifest = so101
    with_realsense(manifest, short_recording)
    data = yaml.safe_load(manifest.read_text())
    data["hardware"]["cameras"]["wrist_depth"] = {"type": "opencv", "index_or_path": 0, "width": W, "height": H}
    manifest.write_text(yaml.safe_dump(data, sort_keys=False))
    r = run_inproc("record", "--hal", "so101_follower", "--mode", "real", "--rskill", "sweep-so-arm",
                   "--port", bus.port, "--out", str(tmp_path / "a"))  # fmt: skip
    assert r.returncode == 2 and "hardware.cameras.wrist.use_depth: its depth stream 'wrist_depth'" in r.stderr


def test_stamps_increase_and_colour_is_exact_straight_from_the_camera(short_recording: Path) -> None:
    """The capture thread alone (no loop, no codec): every sample is a source frame, pixel for pixel."""
    cams, samples = collect(short_recording, 0.5)
    assert len(samples) >= 3
    for s, d in samples:
        k = nearest(s.image)[0]
        assert np.array_equal(s.image, source_frame(k)) and d.seq == s.seq and d.stamp == s.stamp
        assert d.image.dtype == np.uint16 and d.image.shape == (H, W)
    assert all(b[0].stamp > a[0].stamp for a, b in itertools.pairwise(samples))
    assert cams["wrist"].shape.info["camera_info"]["k"] == pytest.approx([FX, 0, CX, 0, FY, CY, 0, 0, 1])


def collect(
    recording: Path, seconds: float, **extra: Any
) -> tuple[dict[str, Any], list[tuple[CameraSample, CameraSample]]]:
    """The cameras of `wrist` playing `recording` (stopped) and every new (colour, depth) pair it handed out in
    `seconds`."""
    cams = start_wrist(recording, **extra)
    samples: list[tuple[CameraSample, CameraSample]] = []
    try:
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            s, d = cams["wrist"].latest(), cams["wrist_depth"].latest()
            if s is not None and d is not None and (not samples or s.seq != samples[-1][0].seq):
                samples.append((s, d))
            time.sleep(0.002)
    finally:
        cams["wrist"].stop()
    return cams, samples


def start_wrist(recording: Path, **extra: Any) -> dict[str, Any]:
    """The manifest camera `wrist` playing `recording`, started (the caller stops it)."""
    from openral_data.producers.hal.robots.lerobot_hw import make_cameras
    from openral_data.schemas.hal import HardwareConfig

    spec = {"type": "intelrealsense", "serial_number_or_name": SERIAL, "width": W, "height": H, "fps": RATE,
            "use_depth": True, "playback": str(recording), **extra}  # fmt: skip
    cams = make_cameras(HardwareConfig(driver="lerobot", robot={"type": "x"}, cameras={"wrist": spec}), "robot.yaml")
    assert list(cams) == ["wrist", "wrist_depth"]
    cams["wrist"].start()
    return cams


def test_depth_in_other_units_is_recorded_in_millimetres(tmp_path: Path) -> None:
    """A camera whose depth unit is 0.1 mm (the D405's): the device's depth scale is applied."""
    cams = start_wrist(record(tmp_path / "d405.db3", 8, depth_units=0.0001))
    try:
        time.sleep(0.2)
        depth = cams["wrist_depth"].latest()
    finally:
        cams["wrist"].stop()
    assert depth is not None and depth.image.dtype == np.uint16
    kd = nearest_depth(depth.image * 10.0)  # 0.1 mm units
    valid = depth.image > 0
    want = np.rint(depth_frame(kd) / 10.0)
    assert valid.mean() > 0.8 and (np.abs(depth.image[valid] - want[valid]) <= 1).all()


LOOP = 12  # frames of the looped recording (0.8 s at RATE)


def test_a_repeated_playback_delivers_the_recording_again_in_order(tmp_path: Path) -> None:
    """`playback_repeat: true`: after its last frame the recording plays from its first again, colour frames the
    source frames in cycle order, each with the aligned depth of its own frameset (the SDK may complete a pass's
    first frameset with the last pass's colour: one frame apart), and our stamps keep increasing though the SDK's
    go back."""
    recording = record(tmp_path / "loop.db3", LOOP)
    reference = aligned_reference(LOOP)
    _, samples = collect(recording, 3.0, playback_repeat=True)
    colour = [nearest(s.image)[0] for s, _ in samples]
    for (s, d), k in zip(samples, colour, strict=True):
        assert np.array_equal(s.image, source_frame(k)) and d.seq == s.seq and d.stamp == s.stamp
        kd = nearest_depth(d.image)
        assert kd == k or (k == LOOP - 1 and kd < LOOP // 2), (k, kd)  # else a new pass's first beside a stale colour
        assert np.array_equal(d.image, reference[kd]), kd
    steps = [(b - a) % LOOP for a, b in itertools.pairwise(colour)]
    # in cycle order: forward, by less than half the recording (a pass may skip its first colour, a loaded machine
    # a sample between two polls; the same colour twice is the last one beside the next pass's first depth)
    assert all(step <= LOOP // 2 for step in steps) and sum(step > 2 for step in steps) <= len(steps) // 4, colour
    passes = 1 + sum(b < a for a, b in itertools.pairwise(colour))
    assert passes >= 3, colour  # 3 s of a 0.8 s recording
    stale = sum(nearest_depth(d.image) != k for (_, d), k in zip(samples, colour, strict=True))
    assert stale <= 3 * (passes - 1), stale  # a restart's first framesets at most
    assert all(b[0].stamp > a[0].stamp for a, b in itertools.pairwise(samples))


@pytest.mark.slow
def test_without_repeat_a_playback_ends_after_one_pass(tmp_path: Path) -> None:
    """The same recording without `playback_repeat`: its frames once, in order, then nothing (slow: stopping a
    camera whose playback ended waits out lerobot's read timeout, 10 s)."""
    once = [nearest(s.image)[0] for s, _ in collect(record(tmp_path / "once.db3", LOOP), 2.0)[1]]
    assert once == sorted(set(once)) and once[-1] == LOOP - 1 and len(once) >= LOOP // 2, once  # each at most once


@pytest.mark.parametrize(("extra", "says"), [
    ({"playback_repeat": "yes"}, "wrist.playback_repeat: true or false, got 'yes'"),
    ({"playback": None, "playback_repeat": True}, "wrist.playback_repeat: repeats a `playback:` recording"),
])  # fmt: skip
def test_a_playback_repeat_that_is_not_a_bool_or_has_no_recording_is_one_line(
    short_recording: Path, extra: dict[str, Any], says: str
) -> None:
    from openral_data.errors import ConfigError

    with pytest.raises(ConfigError) as err:
        start_wrist(short_recording, **extra)
    assert str(err.value).startswith("robot.yaml: hardware.cameras.") and says in str(err.value), err.value
