"""Capture benchmark: N real-time 640x480@30 cameras (and K RealSense, colour + depth) and the SO-101 recorded
by `record --hal` at 30 fps.

Workload (one session per codec and N, each in a fresh process so its CPU time and peak RSS are its own):

* the SO-101 follower on a SIMULATED Feetech bus (tests/support/feetech_bus.py: a pty speaking the servo
  protocol) served by its own process, as a real arm's servos answer from their own hardware (a thread of the
  recorder's process, the simulation would compete with the loop for the GIL; its CPU is not counted), driven
  by the `sweep-so-arm` rSkill through `record_hal` (`--mode real`), one episode of `--seconds` seconds at
  `--fps` (the real fixed-rate loop, safety filter, bridge and LeRobot v3 writer, which spills frames to disk
  when an encoder falls behind);
* N cameras, each lerobot 0.6.1's `OpenCVCamera` (opencv-python-headless) reading a named pipe into which a
  separate feeder process writes a live stream: lossless NUT (rawvideo bgr24, what tests/producers/
  test_opencv_camera.py feeds) at 640x480, paced at 30 frames a second (a moving bar over noise, so encoders
  have real work). The feeders run in their own processes: the session's CPU time is the recorder's alone;
* `--realsense K` RealSense cameras beside them (`--cameras 0` for RealSense alone), colour and depth at
  640x480@30, each playing its own SDK recording (its own serial number) through lerobot's `RealSenseCamera`
  (pyrealsense2; the manifest's `playback:` with `playback_repeat: true`): made once per run, untimed, by
  tests/support/realsense.py (`rs.software_device` recorded by `rs.recorder`, 3 s: colour like the OpenCV
  sources, depth a millimetre slope moving 25 mm a frame, 30 distinct frames, so a pass ends where it began)
  and looped by the SDK. Ours records the colour as `rs<i>` and the depth aligned to it as `rs<i>_depth`
  (lerobot's 12-bit HEVC depth video). The SDK's playback runs in the recorder's process: its CPU is counted.

Reported per session: loop overruns and missed ticks; per camera (a RealSense's colour and depth each) the frames
recorded (rows) and the frames in its video (must be equal), the samples recorded twice (repeats: the loop took a
sample it had already recorded), the frames spilled, the sample age at the tick (p50 / p99 / max, ms) and the
encoder lag (the longest a frame waited to be encoded, ms); the recorder's CPU seconds per camera-second of
recording (a RealSense is one camera, N + K in all) and its peak RSS (MB); and the wall time of the whole session
(the episode's commit waits for spilled frames to be encoded).

`--recorders lerobot,lerobot-streaming` adds, on the same robot, bus and sources, lerobot 0.6.1's own recorder
(`lerobot-record`'s `record_loop` with its `LeRobotDataset` writer, default and `streaming_encoding=True`;
capture_lerobot.py) as the anchor: its frames vs the ticks due, its overruns (its own "running slower" warnings),
frames in each video, CPU, RSS and the time to its saved episode. Its RealSense cameras are lerobot's own
`RealSenseCamera` (use_depth) playing the same recordings, looped, with only the recording set (depth unaligned,
as lerobot records it; its depth video is lerobot's default, 12-bit HEVC).

Run (from the repository root; the machine should be otherwise idle for the real-time numbers)::

    MUJOCO_GL=egl .venv/bin/python benchmarks/bench_capture.py --cameras 1,2,3 --codecs h264 --seconds 20
    MUJOCO_GL=egl .venv/bin/python benchmarks/bench_capture.py --cameras 1,2,3,4,5,6 --codecs h264,av1,auto \\
        --recorders ours,lerobot,lerobot-streaming --seconds 600 --json capture.json   # the 10-minute sessions
    MUJOCO_GL=egl .venv/bin/python benchmarks/bench_capture.py --cameras 0,1 --realsense 1 --codecs h264 \
        --recorders ours,lerobot --seconds 600   # with a RealSense (colour + depth from SDK playback)
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))
W, H, RATE = 640, 480, 30
DISTINCT = 30  # distinct source images, cycled (a second of video)
RS_SECONDS = 3  # each RealSense recording (looped by the SDK): 3 passes of the DISTINCT frames, ~140 MB
RS_SERIAL = 100000000  # RealSense camera i has serial number RS_SERIAL + i


# -- the live sources (feeder processes) ------------------------------------------------------------------
def source_frames(seed: int) -> list[npt.NDArray[np.uint8]]:
    """`DISTINCT` 640x480 BGR images like a camera's: smooth gradients with a little sensor noise (+-6), under a
    bar that moves one step a frame."""
    rng = np.random.default_rng(seed)
    y, x = np.mgrid[0:H, 0:W]
    smooth = np.stack([x * 255 // W, y * 255 // H, (x + y) * 255 // (W + H)], axis=-1) + seed * 20
    base = np.clip(smooth + rng.integers(-6, 7, (H, W, 3)), 0, 255).astype(np.uint8)
    frames = []
    for k in range(DISTINCT):
        img = base.copy()
        x = k * W // DISTINCT
        img[:, x : x + W // DISTINCT] = (40, 200, 90)
        frames.append(img)
    return frames


def feed(pipe: str, seconds: float, seed: int) -> None:
    """Write a live rawvideo NUT stream into `pipe` at RATE frames a second for `seconds` (then stop)."""
    import av

    frames = source_frames(seed)
    # the reader going away (the session ended) ends the feed: a broken pipe, which PyAV reports as its own error
    with (
        contextlib.suppress(OSError, av.error.FFmpegError),
        open(pipe, "wb") as fh,
        av.open(fh, "w", format="nut") as out,
    ):
        stream = out.add_stream("rawvideo", rate=RATE)
        assert isinstance(stream, av.VideoStream)
        stream.width, stream.height, stream.pix_fmt = W, H, "bgr24"
        t0 = time.monotonic()
        k = 0
        while time.monotonic() - t0 < seconds:
            frame = av.VideoFrame.from_ndarray(frames[k % DISTINCT], format="bgr24")
            frame.pts = k
            for packet in stream.encode(frame):
                out.mux(packet)
            fh.flush()
            k += 1
            wait = t0 + k / RATE - time.monotonic()
            if wait > 0:
                time.sleep(wait)


# -- the RealSense recordings (made once per run, untimed) ----------------------------------------------------
def rs_recording(work: Path, i: int) -> tuple[str, Path]:
    """RealSense camera i's serial number and SDK recording in `work`."""
    return str(RS_SERIAL + i), work / f"rs{i}.db3"


def make_recordings(work: Path, k: int) -> None:
    """K SDK recordings of RS_SECONDS at RATE: colour like `source_frames` (seed 10 + i), depth a slope in mm."""
    from tests.support.realsense import SoftwareRealSense, record_sdk, slope_mm

    for i in range(k):
        serial, path = rs_recording(work, i)
        frames = [np.ascontiguousarray(f[..., ::-1]) for f in source_frames(10 + i)] * RS_SECONDS  # RGB
        cam = SoftwareRealSense(
            colour=frames.__getitem__, depth=lambda n: slope_mm(W, H, n % DISTINCT),
            width=W, height=H, rate=RATE, serial=serial, fx=615.0, fy=615.0, cx=319.5, cy=239.5,
        )  # fmt: skip
        record_sdk(cam, path, RS_SECONDS * RATE)


# -- the simulated servo bus (its own process) --------------------------------------------------------------
def serve_bus() -> None:
    """Be the simulated SO-101 bus: print its port, serve it until stdin closes (the session ended)."""
    from tests.support.feetech_bus import SimulatedFeetechBus

    with SimulatedFeetechBus(list(range(1, 7))) as bus:
        print(bus.port, flush=True)
        sys.stdin.read()


@contextlib.contextmanager
def bus_process() -> Iterator[str]:
    """A `serve_bus` process; its port. The SDK's packet timeout gets the simulated bus's patience in this process
    (tests/support/pty_device.py: a late simulated reply is not a missing servo)."""
    from scservo_sdk.port_handler import PortHandler

    from tests.support.pty_device import patient_is_packet_timeout

    proc = subprocess.Popen(
        [sys.executable, __file__, "--bus"], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True
    )
    original = PortHandler.isPacketTimeout
    try:
        assert proc.stdout is not None and proc.stdin is not None
        port = proc.stdout.readline().strip()
        if not port:
            raise RuntimeError("the simulated bus did not start")
        PortHandler.isPacketTimeout = patient_is_packet_timeout
        yield port
    finally:
        PortHandler.isPacketTimeout = original
        if proc.stdin is not None:
            proc.stdin.close()
        try:
            proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()


# -- one session (its own process) ------------------------------------------------------------------------
def with_cameras(manifest: Path, pipes: list[str], recordings: list[tuple[str, Path]]) -> None:
    import yaml

    data = yaml.safe_load(manifest.read_text())
    data["hardware"]["calibration_dir"] = "calibration"
    data["hardware"]["cameras"] = {
        f"cam{i}": {"type": "opencv", "index_or_path": p, "width": W, "height": H, "fps": RATE, "warmup_s": 0}
        for i, p in enumerate(pipes)
    }
    for i, (serial, path) in enumerate(recordings):
        data["hardware"]["cameras"][f"rs{i}"] = {
            "type": "intelrealsense", "serial_number_or_name": serial, "width": W, "height": H, "fps": RATE,
            "use_depth": True, "playback": str(path), "playback_repeat": True,
        }  # fmt: skip
    manifest.write_text(yaml.safe_dump(data, sort_keys=False))


def camera_names(cameras: int, realsense: int) -> list[str]:
    """The recorded cameras: the OpenCV ones, then each RealSense's colour and depth."""
    return [f"cam{i}" for i in range(cameras)] + [f"rs{i}{d}" for i in range(realsense) for d in ("", "_depth")]


def session(
    codec: str, cameras: int, realsense: int, seconds: float, fps: int, work: Path, rs_dir: Path | None, recorder: str
) -> dict[str, Any]:
    """Record one episode of `seconds` with `cameras` live sources and `realsense` RealSense playing the
    recordings in `rs_dir` (`recorder`: ours, lerobot or lerobot-streaming); the measurements."""
    from tests.support.feetech_bus import write_so_calibration
    from tests.support.home import isolated_home

    pipes = []
    for i in range(cameras):
        pipe = work / f"cam{i}.nut"
        os.mkfifo(pipe)
        pipes.append(str(pipe))
    feeders = [
        subprocess.Popen([sys.executable, __file__, "--feed", p, "--seconds", str(seconds + 60), "--seed", str(i)])
        for i, p in enumerate(pipes)
    ]
    recordings = [rs_recording(rs_dir, i) for i in range(realsense)] if rs_dir is not None else []
    out = work / "ds"
    try:
        with isolated_home(work) as home, bus_process() as port:
            manifest = home / "robots" / "so101_follower" / "robot.yaml"
            write_so_calibration(manifest.parent / "calibration" / "so101_follower.json")
            if recorder != "ours":
                from capture_lerobot import lerobot_session

                got = lerobot_session(pipes, recordings, port, manifest.parent / "calibration", seconds, fps, out,
                                      codec, recorder == "lerobot-streaming")  # fmt: skip
                return anchor_row(got, recorder, codec, cameras, realsense, seconds)
            with_cameras(manifest, pipes, recordings)
            return ours(manifest, port, codec, cameras, realsense, seconds, fps, out)
    finally:
        for f in feeders:
            f.kill()
            f.wait()


def ours(
    manifest: Path, port: str, codec: str, cameras: int, realsense: int, seconds: float, fps: int, out: Path
) -> dict[str, Any]:
    """`record --hal so101_follower` (its Python API) for one episode; the CPU and wall time from the episode's
    start to its commit (its videos complete)."""
    from openral_data.record.hal import HalRecordOptions, record_hal

    opts = HalRecordOptions(
        robot="so101_follower", rskill="sweep-so-arm", mode="real", port=port, fps=fps, episode_time_s=seconds,
        out=out, codec=codec, operator="success",  # type: ignore[arg-type]
    )  # fmt: skip
    stamps: dict[str, tuple[os.times_result, float]] = {}

    def stamp(line: str) -> None:  # the episode starts recording ... is committed (its videos encoded)
        key = "start" if ": recording" in line else "end" if ": kept" in line else None
        if key is not None:
            stamps[key] = (os.times(), time.perf_counter())

    summary = record_hal(opts, notify=stamp)
    (cpu0, t0), (cpu1, t1) = stamps["start"], stamps["end"]
    cpu = (cpu1.user - cpu0.user) + (cpu1.system - cpu0.system)
    return measure(summary, out, codec, cameras, realsense, seconds, fps, cpu, t1 - t0)


def anchor_row(
    got: dict[str, Any], recorder: str, codec: str, cameras: int, realsense: int, seconds: float
) -> dict[str, Any]:
    return {
        "recorder": recorder,
        "codec": codec,
        "cameras": cameras,
        "realsense": realsense,
        "seconds": seconds,
        "ticks": got["ticks_due"],
        "frames": got["frames"],
        "overruns": got["overruns"],
        "in_video": got["in_video"],
        "wall_s": got["wall_s"],
        "cpu_s_per_camera_s": round(got["cpu_s"] / (cameras + realsense) / seconds, 3),
        "peak_rss_mb": round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, 0),
        "depth_videos": got["depth_videos"],
    }


def measure(
    summary: Any,
    out: Path,
    codec: str,
    cameras: int,
    realsense: int,
    seconds: float,
    fps: int,
    cpu: float,
    wall: float,
) -> dict[str, Any]:
    from openral_data.formats.lerobot_v3.video import probe_frames
    from tests.support.hal import episode_infos, frames_table

    report = summary.all_reports[0]
    cols = frames_table(out)
    info = episode_infos(out)[0]
    missed, ticks = cols["openral.ticks_missed"], cols["openral.tick"]
    per_camera = {}
    for name in camera_names(cameras, realsense):
        ages = np.asarray(cols[f"openral.sample_age.{name}"]) * 1000
        video = next((out / "videos" / f"observation.images.{name}").rglob("*.mp4"))
        per_camera[name] = {
            "rows": len(ages),
            "in_video": probe_frames(video),
            "repeats": report.repeated[name],
            "stale_ticks": report.stale[name],
            "spilled": info["capture"][name]["spilled"],
            "age_p50_ms": round(float(np.percentile(ages, 50)), 1),
            "age_p99_ms": round(float(np.percentile(ages, 99)), 1),
            "age_max_ms": round(float(ages.max()), 1),
            "encoder_lag_ms": round(info["capture"][name]["encoder_lag_s"] * 1000, 1),
        }
    return {
        "recorder": "ours",
        "codec": codec,
        "cameras": cameras,
        "realsense": realsense,
        "seconds": seconds,
        "ticks": report.ticks,
        "frames": report.frames,
        "overruns": report.overruns,
        "missed_ticks": report.missed_ticks,
        "missed_after_1s": int(sum(m for m, t in zip(missed, ticks, strict=True) if t >= fps)),
        "stale_ticks": report.stale_ticks,
        "wall_s": round(wall, 1),
        "cpu_s_per_camera_s": round(cpu / (cameras + realsense) / seconds, 3),
        "peak_rss_mb": round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, 0),
        "per_camera": per_camera,
    }


def run_one(
    recorder: str, codec: str, cameras: int, realsense: int, seconds: float, fps: int, rs_dir: Path | None
) -> dict[str, Any]:
    """One session in a fresh process (its CPU and RSS its own); its JSON line."""
    with tempfile.TemporaryDirectory(prefix="bench_capture_") as tmp:
        args = ["--one", codec, "--cameras", str(cameras), "--seconds", str(seconds), "--fps", str(fps)]
        args += ["--recorder", recorder, "--realsense", str(realsense)]
        args += ["--recordings", str(rs_dir)] if rs_dir is not None else []
        proc = subprocess.run(
            [sys.executable, __file__, *args, "--work", tmp], capture_output=True, text=True, check=False
        )
    if proc.returncode != 0:
        return {
            "recorder": recorder,
            "codec": codec,
            "cameras": cameras,
            "realsense": realsense,
            "error": proc.stderr.strip().splitlines()[-12:],
        }
    got: dict[str, Any] = json.loads(proc.stdout.strip().splitlines()[-1])
    return got


def row(r: dict[str, Any]) -> str:
    n = f"{r['cameras']}+{r['realsense']} RS" if r.get("realsense") else str(r["cameras"])
    head = f"| {r['recorder']} | {r['codec']} | {n} |"
    if "error" in r:
        return f"{head} error: {r['error']} |"
    if r["recorder"] != "ours":
        return (
            f"{head} {r['frames']}/{r['ticks']} | {r['overruns']} | – | – | "
            f"{'/'.join(f'{r["frames"]}={n}' for n in r['in_video'].values())} | – | – | – | – | "
            f"{r['cpu_s_per_camera_s']} | {r['peak_rss_mb']:.0f} | {r['wall_s']} |"
        )
    cams = r["per_camera"].values()
    written = "/".join(f"{c['rows']}={c['in_video']}" for c in cams)
    return (
        f"{head} {r['frames']}/{r['ticks']} | {r['overruns']} | "
        f"{r['missed_ticks']} ({r['missed_after_1s']}) | {r['stale_ticks']} | "
        f"{written} | {sum(c['repeats'] for c in cams)} | {sum(c['spilled'] for c in cams)} | "
        f"{max(c['age_p50_ms'] for c in cams)} / {max(c['age_p99_ms'] for c in cams)} | "
        f"{max(c['encoder_lag_ms'] for c in cams)} | {r['cpu_s_per_camera_s']} | {r['peak_rss_mb']:.0f} | "
        f"{r['wall_s']} |"
    )


HEADER = (
    "| recorder | codec | N (+K RS) | frames/ticks | overruns | missed (after 1 s) | stale | "
    "rows=in video (per camera) | repeats | spilled | age p50/p99 ms | enc. lag ms | CPU s per cam-s | "
    "peak RSS MB | record+commit s |\n"
    "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"
)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--cameras", default="1,2,3", help="N values, comma-separated (--one: a single N)")
    ap.add_argument("--realsense", type=int, default=0, help="K RealSense cameras (colour + depth) beside the N")
    ap.add_argument("--codecs", default="h264", help="h264, av1 and/or auto, comma-separated")
    ap.add_argument("--seconds", type=float, default=20.0)
    ap.add_argument("--fps", type=int, default=RATE)
    ap.add_argument("--json", type=Path, help="also write every session's measurements here")
    ap.add_argument(
        "--recorders", default="ours", help="ours, lerobot (its default writer), lerobot-streaming; comma-separated"
    )
    ap.add_argument("--recorder", default="ours", help=argparse.SUPPRESS)  # internal: --one's recorder
    ap.add_argument("--feed", help=argparse.SUPPRESS)  # internal: be a feeder process
    ap.add_argument("--bus", action="store_true", help=argparse.SUPPRESS)  # internal: be the simulated bus
    ap.add_argument("--seed", type=int, default=0, help=argparse.SUPPRESS)
    ap.add_argument("--one", help=argparse.SUPPRESS)  # internal: run one session in this process
    ap.add_argument("--work", type=Path, help=argparse.SUPPRESS)
    ap.add_argument("--recordings", type=Path, help=argparse.SUPPRESS)  # internal: --one's RealSense recordings
    args = ap.parse_args()
    if args.feed:
        feed(args.feed, args.seconds, args.seed)
        return
    if args.bus:
        serve_bus()
        return
    if args.one:
        got = session(args.one, int(args.cameras), args.realsense, args.seconds, args.fps, args.work,
                      args.recordings, args.recorder)  # fmt: skip
        print(json.dumps(got))
        return
    with tempfile.TemporaryDirectory(prefix="bench_capture_rs_") as rs_tmp:
        rs_dir = Path(rs_tmp) if args.realsense else None
        if rs_dir is not None:
            t0 = time.perf_counter()
            make_recordings(rs_dir, args.realsense)
            print(f"{args.realsense} RealSense recording(s) of {RS_SECONDS} s made in {time.perf_counter() - t0:.1f} s")
        print(f"load average at start: {os.getloadavg()}; cores: {os.cpu_count()}")
        print(HEADER)
        results = []
        for codec in args.codecs.split(","):
            for n in (int(x) for x in args.cameras.split(",")):
                for recorder in args.recorders.split(","):
                    results.append(run_one(recorder, codec, n, args.realsense, args.seconds, args.fps, rs_dir))
                    print(row(results[-1]), flush=True)
    print(f"load average at end: {os.getloadavg()}")
    if args.json:
        args.json.write_text(json.dumps(results, indent=2))


if __name__ == "__main__":
    main()
