"""Writer benchmark: our LeRobotDataset v3 writer vs lerobot 0.6.1's default writer vs a bare PyAV encode.

Workload W (the defaults): 10 episodes x 200 frames at 20 fps, two RGB cameras (``front``, ``wrist``) of
256x256, ``observation.state`` float32[8], ``action`` float32[7]. Every frame is a step carrying both images.

Three contestants write W in the same process, in this order for each repetition:

1. **pure**: the physical limit. The frames go straight into PyAV (``libsvtav1`` g=2 crf=30 preset=12
   fast-decode=0, or ``libx264`` g=2 crf=30), one mp4 per camera per episode, both cameras fed interleaved
   from one Python thread. No parquet, no stats, no metadata.
2. **ours**: ``DatasetBridge`` (contract validation) -> ``LeRobotV3Writer`` with its default config apart
   from the codec (durable commits, per-episode stats, streaming encoder threads, mp4 joining at close).
3. **lerobot**: ``LeRobotDataset.create(..., use_videos=True)`` + ``add_frame`` / ``save_episode`` /
   ``finalize`` with lerobot's defaults (PNG staging, no streaming encoding, no async image writer). It is
   given the same ``next.reward`` / ``next.done`` / ``next.success`` columns our writer always writes, and
   ``video_backend="pyav"``, which only picks the read-back decoder (the one we use; torchcodec is not installed).
4. **lerobot_stream**: the same with ``streaming_encoding=True`` (lerobot's best: frames go to one encoder
   thread per camera as they arrive, no PNGs) and ``encoder_threads`` as ours gets them.
5. **lerobot_batch** (only when named in ``--contestants``): the default writer with ``batch_encoding_size`` = all
   episodes (PNGs staged, every episode's videos encoded in one batch). lerobot 0.6.1 raises on it for a new
   dataset (``TypeError`` in ``_batch_save_episode_video``: ``meta.episodes`` is None until a reload).

The frames are rendered once, before anything is timed (workload.py): a smooth textured background (a wall and a
table) with a few moving, shaded objects whose positions depend on (episode, step, camera); the wrist camera also
pans. That is roughly what a simulator renders: neither random noise (far harder to encode) nor flat colour
(far easier). States and actions are deterministic float32 arrays.

After each timed run (outside the timed region) the script demuxes every mp4 of our and lerobot's datasets,
compares the video frame count of each camera with the parquet row count ("dropped frames"), and loads our
dataset with ``LeRobotDataset`` to check ``len(ds) == episodes * frames``. It prints a table of median wall
times, frames/s and the ratios (ours speedup over lerobot = lerobot / ours; ours vs pure encode = pure / ours,
at most ~1), and writes everything to ``<out>/results.json``.

The machine this was written for has two shared, noisy cores, so compare the ratios from one process rather
than absolute times across runs.

Run (from the repository root)::

    .venv/bin/python benchmarks/bench_writer.py                           # workload W, a few minutes
    .venv/bin/python benchmarks/bench_writer.py --episodes 2 --frames 40  # smoke run
    .venv/bin/python benchmarks/bench_writer.py --repeats 3 --codec h264 --out benchmarks/results --keep
    .venv/bin/python benchmarks/bench_writer.py --contestants pure,ours,lerobot_stream   # ours vs lerobot's best
"""

from __future__ import annotations

import argparse
import gc
import importlib
import importlib.metadata
import json
import os
import platform
import shutil
import statistics
import sys
import tempfile
import time
import warnings
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from datetime import UTC, datetime
from fractions import Fraction
from pathlib import Path
from typing import Any, cast

import av
import numpy as np
import pyarrow.parquet as pq
from workload import Codec, EpisodeData, Workload, bench_schema, feed_bridge, make_data

CONTESTANTS = ("pure", "ours", "lerobot", "lerobot_stream", "lerobot_batch")
LEROBOT = ("lerobot", "lerobot_stream", "lerobot_batch")
IMAGE_PREFIX = "observation.images."


# -- contestants -------------------------------------------------------------------------------------------
def pure_encoder(codec: Codec) -> tuple[str, dict[str, str]]:
    if codec == "av1":
        return "libsvtav1", {"g": "2", "crf": "30", "preset": "12", "svtav1-params": "fast-decode=0"}
    return "libx264", {"g": "2", "crf": "30"}


def run_pure(data: list[EpisodeData], root: Path, wl: Workload, codec: Codec) -> None:
    """The physical limit: only the video encode, one thread, both cameras interleaved."""
    encoder, options = pure_encoder(codec)
    for e, ep in enumerate(data):
        containers: dict[str, Any] = {}
        streams: dict[str, Any] = {}
        for cam in wl.cameras:
            path = root / f"{IMAGE_PREFIX}{cam}" / f"episode-{e:06d}.mp4"
            path.parent.mkdir(parents=True, exist_ok=True)
            containers[cam] = av.open(str(path), "w")
            stream = containers[cam].add_stream(encoder, rate=wl.fps, options=options)
            stream.width, stream.height, stream.pix_fmt = wl.width, wl.height, "yuv420p"
            stream.codec_context.time_base = Fraction(1, wl.fps)
            streams[cam] = stream
        for t in range(wl.frames):
            for cam in wl.cameras:
                vf = av.VideoFrame.from_ndarray(ep.images[cam][t], format="rgb24")
                vf.pts = t
                for packet in streams[cam].encode(vf):
                    containers[cam].mux(packet)
        for cam in wl.cameras:
            for packet in streams[cam].encode(None):
                containers[cam].mux(packet)
            containers[cam].close()


def run_ours(data: list[EpisodeData], root: Path, wl: Workload, codec: Codec) -> None:
    from openral_data.formats.lerobot_v3 import LeRobotV3Writer, VideoSettings, WriterConfig

    video = VideoSettings(codec=codec, threads=KNOBS["encoder_threads"])
    feed_bridge([LeRobotV3Writer(root, bench_schema(wl), WriterConfig(video=video))], data, wl)


def lerobot_features(wl: Workload) -> dict[str, dict[str, Any]]:
    features: dict[str, dict[str, Any]] = {
        f"{IMAGE_PREFIX}{cam}": {
            "dtype": "video",
            "shape": (wl.height, wl.width, 3),
            "names": ["height", "width", "channels"],
        }
        for cam in wl.cameras
    }
    features["observation.state"] = {
        "dtype": "float32",
        "shape": (wl.state_dim,),
        "names": [f"s{i}" for i in range(wl.state_dim)],
    }
    features["action"] = {
        "dtype": "float32",
        "shape": (wl.action_dim,),
        "names": [f"a{i}" for i in range(wl.action_dim)],
    }
    # the outcome columns our writer always writes, so both parquet files carry the same data
    features["next.reward"] = {"dtype": "float32", "shape": (1,), "names": None}
    features["next.done"] = {"dtype": "bool", "shape": (1,), "names": None}
    features["next.success"] = {"dtype": "bool", "shape": (1,), "names": None}
    return features


def run_lerobot(data: list[EpisodeData], root: Path, wl: Workload, codec: Codec, **knobs: Any) -> None:
    """lerobot's writer; `knobs` are `LeRobotDataset.create`'s (streaming_encoding, batch_encoding_size, ...)."""
    from lerobot.configs.video import RGBEncoderConfig
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    # av1 is lerobot's default (libsvtav1, preset 12); for h264 only the codec is changed
    rgb_encoder = None if codec == "av1" else RGBEncoderConfig(vcodec="h264")
    ds = LeRobotDataset.create(
        "bench/lerobot",
        fps=wl.fps,
        features=lerobot_features(wl),
        root=root,
        robot_type="bench",
        use_videos=True,
        rgb_encoder=rgb_encoder,
        video_backend="pyav",  # read-back decoder only (torchcodec is not installed: docs/recording.md)
        **knobs,
    )
    last = wl.frames - 1
    reward = np.zeros(1, np.float32)
    not_success = np.zeros(1, bool)
    try:
        for ep in data:
            for t in range(wl.frames):
                frame: dict[str, Any] = {f"{IMAGE_PREFIX}{cam}": ep.images[cam][t] for cam in wl.cameras}
                frame["observation.state"] = ep.states[t]
                frame["action"] = ep.actions[t]
                frame["next.reward"] = reward
                frame["next.done"] = np.array([t == last])
                frame["next.success"] = not_success
                frame["task"] = wl.task
                ds.add_frame(frame)
            ds.save_episode()
    finally:
        ds.finalize()


def run_lerobot_stream(data: list[EpisodeData], root: Path, wl: Workload, codec: Codec) -> None:
    from openral_data.formats.lerobot_v3.encoder import VideoSettings, encoder_threads

    threads = encoder_threads(VideoSettings(codec=codec, threads=KNOBS["encoder_threads"]), len(wl.cameras))
    run_lerobot(data, root, wl, codec, streaming_encoding=True, encoder_threads=threads)


def run_lerobot_batch(data: list[EpisodeData], root: Path, wl: Workload, codec: Codec) -> None:
    run_lerobot(data, root, wl, codec, batch_encoding_size=wl.episodes)


KNOBS: dict[str, int | None] = {"encoder_threads": None}  # --encoder-threads per camera (None: cores / cameras)
RUNNERS: dict[str, Callable[[list[EpisodeData], Path, Workload, Codec], None]] = {
    "pure": run_pure,
    "ours": run_ours,
    "lerobot": run_lerobot,
    "lerobot_stream": run_lerobot_stream,
    "lerobot_batch": run_lerobot_batch,
}


# -- measurement and checks --------------------------------------------------------------------------------
@dataclass
class RunResult:
    wall_s: float
    cpu_s: float  # this process and its reaped children (lerobot encodes in a process pool)
    video_bytes: int
    video_frames: dict[str, int] = field(default_factory=dict)  # camera key -> demuxed frames
    parquet_rows: int | None = None
    dropped: int | None = None
    loaded_len: int | None = None


def _cpu_seconds() -> float:
    t = os.times()
    return t.user + t.system + t.children_user + t.children_system


def timed(name: str, data: list[EpisodeData], root: Path, wl: Workload, codec: Codec) -> tuple[float, float]:
    gc.collect()
    cpu0, t0 = _cpu_seconds(), time.perf_counter()
    RUNNERS[name](data, root, wl, codec)
    wall = time.perf_counter() - t0
    return wall, _cpu_seconds() - cpu0


def count_packets(path: Path) -> int:
    with av.open(str(path)) as c:
        n = sum(1 for p in c.demux(c.streams.video[0]) if p.size)
    return n


def video_frames(root: Path) -> dict[str, int]:
    """Demuxed video frames per camera key, over every mp4 under ``root/videos`` (or ``root`` for pure)."""
    base = root / "videos" if (root / "videos").is_dir() else root
    counts: dict[str, int] = {}
    for mp4 in sorted(base.rglob("*.mp4")):
        key = mp4.relative_to(base).parts[0]
        counts[key] = counts.get(key, 0) + count_packets(mp4)
    return counts


def parquet_rows(root: Path) -> int:
    return sum(pq.ParquetFile(p).metadata.num_rows for p in sorted((root / "data").rglob("*.parquet")))


def video_bytes(root: Path) -> int:
    return sum(p.stat().st_size for p in root.rglob("*.mp4"))


def check(name: str, root: Path, wl: Workload, result: RunResult) -> None:
    """Count frames (and rows, and what lerobot loads) after a run; fills `result`, never timed."""
    keys = [f"{IMAGE_PREFIX}{cam}" for cam in wl.cameras]
    frames = video_frames(root)
    result.video_frames = {k: frames.get(k, 0) for k in keys}
    if name == "pure":
        result.dropped = sum(wl.total_frames - n for n in result.video_frames.values())
        return
    rows = parquet_rows(root)
    result.parquet_rows = rows
    # a missing row is as lost as a missing video frame: count both against the frames that were written
    result.dropped = sum(abs(rows - n) for n in result.video_frames.values()) + len(keys) * abs(wl.total_frames - rows)
    if name == "ours":  # (a lerobot contestant's loss shows as dropped frames: lerobot_stream has lost one)
        from lerobot.datasets.lerobot_dataset import LeRobotDataset

        ds = LeRobotDataset("bench/ours", root=root, video_backend="pyav")
        result.loaded_len = len(ds)
        del ds


def offline_in(scratch: Path) -> None:
    """No network here: nothing may try the Hub, and the Hugging Face caches stay in the scratch directory."""
    os.environ["HF_HUB_OFFLINE"] = "1"
    os.environ["HF_DATASETS_OFFLINE"] = "1"
    os.environ["HF_HUB_DISABLE_TELEMETRY"] = "1"
    os.environ["HF_DATASETS_DISABLE_PROGRESS_BARS"] = "1"
    warnings.filterwarnings("ignore", message="Cannot enable progress bars", category=UserWarning)
    os.environ["HF_LEROBOT_HOME"] = str(scratch / "hf_lerobot_home")
    os.environ["HF_DATASETS_CACHE"] = str(scratch / "hf_datasets_cache")


# -- reporting ---------------------------------------------------------------------------------------------
def machine_info() -> dict[str, Any]:
    cpu_model = ""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu_model = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    versions: dict[str, str | None] = {}
    for dist in ("lerobot", "av", "numpy", "pyarrow", "datasets", "torch"):
        try:
            versions[dist] = importlib.metadata.version(dist)
        except importlib.metadata.PackageNotFoundError:
            versions[dist] = None
    return {
        "nproc": os.cpu_count(),
        "affinity_cpus": len(os.sched_getaffinity(0)),
        "cpu_model": cpu_model,
        "platform": platform.platform(),
        "python": sys.version.split()[0],
        "av_version": av.__version__,
        "lerobot_version": versions["lerobot"],
        "versions": versions,
        "ffmpeg_libraries": {k: ".".join(map(str, v)) for k, v in av.library_versions.items()},
        "loadavg_at_start": os.getloadavg(),
    }


def _fmt_ratio(x: float) -> str:
    return f"{x:.2f}x"


def print_table(wl: Workload, codec: Codec, results: dict[str, list[RunResult]], summary: dict[str, Any]) -> None:
    repeats = len(results["ours"])
    print()
    print(
        f"workload: {wl.episodes} episodes x {wl.frames} frames, cameras {', '.join(wl.cameras)} "
        f"{wl.width}x{wl.height}, state f32[{wl.state_dim}], action f32[{wl.action_dim}], {wl.fps} fps, "
        f"codec {codec}, median of {repeats}"
    )
    header = f"{'contestant':<14} {'wall s':>9} {'frames/s':>9} {'cpu s':>8} {'video MB':>9}  runs (wall s)"
    print(header)
    print("-" * len(header))
    for name, runs_of in results.items():
        med = summary["median_wall_s"][name]
        runs = " ".join(f"{r.wall_s:.2f}" for r in runs_of)
        print(
            f"{name:<14} {med:>9.2f} {summary['frames_per_s'][name]:>9.1f} "
            f"{summary['median_cpu_s'][name]:>8.1f} {summary['video_mb'][name]:>9.2f}  {runs}"
        )
    ratios = summary["ratios"]
    print()
    for name in (n for n in LEROBOT if n in results):
        print(f"ours speedup over {name:<15} ({name} / ours): {_fmt_ratio(ratios[f'ours_speedup_vs_{name}'])}")
    print(f"ours vs pure encode       (pure / ours):      {ratios['ours_vs_pure_encode']:.3f}")
    for name in (n for n in LEROBOT if n in results):
        print(f"{name:<15} vs pure encode (pure / {name}): {ratios[f'{name}_vs_pure_encode']:.3f}")
    print("frames kept (per camera, min): " + ", ".join(f"{n} {summary['frames_kept'][n]}" for n in results))
    dropped = summary["dropped_frames"]
    print("dropped frames: " + ", ".join(f"{n} {dropped[n]}" for n in results if n != "pure"))
    print(f"LeRobotDataset(ours) len: {summary['ours_loaded_len']} (expected {wl.total_frames})")


def summarize(wl: Workload, results: dict[str, list[RunResult]]) -> dict[str, Any]:
    names = list(results)
    med = {n: statistics.median(r.wall_s for r in results[n]) for n in names}
    ratios = {"ours_vs_pure_encode": med["pure"] / med["ours"]}
    for name in (n for n in LEROBOT if n in med):
        ratios |= {
            f"ours_speedup_vs_{name}": med[name] / med["ours"],
            f"{name}_vs_pure_encode": med["pure"] / med[name],
        }
    return {
        "median_wall_s": med,
        "median_cpu_s": {n: statistics.median(r.cpu_s for r in results[n]) for n in names},
        "frames_per_s": {n: wl.total_frames / med[n] for n in names},
        "video_mb": {n: statistics.median(r.video_bytes for r in results[n]) / 1e6 for n in names},
        "ratios": ratios,
        "dropped_frames": {n: max(r.dropped or 0 for r in results[n]) for n in names},
        "frames_kept": {n: min(min(r.video_frames.values(), default=0) for r in results[n]) for n in names},
        "ours_loaded_len": min(r.loaded_len or 0 for r in results["ours"]),
    }


# -- main --------------------------------------------------------------------------------------------------
def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0] if __doc__ else None)
    p.add_argument("--episodes", type=int, default=10)
    p.add_argument("--frames", type=int, default=200, help="frames (time steps) per episode")
    p.add_argument("--repeats", type=int, default=1, help="repetitions of pure, ours, lerobot (median reported)")
    p.add_argument("--codec", choices=["av1", "h264"], default="av1")
    p.add_argument("--out", type=Path, default=Path(__file__).resolve().parent / "results", help="results.json dir")
    p.add_argument("--tmp", type=Path, default=None, help="parent of the scratch directory (default: system temp)")
    p.add_argument("--keep", action="store_true", help="keep the written datasets")
    p.add_argument("--no-lerobot", action="store_true", help="only pure and ours (the ours/pure ratio, faster)")
    default = ",".join(CONTESTANTS[:-1])  # lerobot_batch fails in lerobot 0.6.1 (above): named only
    p.add_argument("--contestants", default=default, help=f"comma-separated, of {', '.join(CONTESTANTS)}")
    p.add_argument(
        "--encoder-threads",
        type=int,
        default=None,
        help="ours' (and lerobot_stream's) per camera; 0: the encoder's own default",
    )
    args = p.parse_args(argv)
    unknown = set(args.contestants.split(",")) - set(CONTESTANTS)
    if unknown or not {"pure", "ours"} <= set(args.contestants.split(",")):
        p.error(f"--contestants: {', '.join(sorted(unknown)) or 'pure and ours are needed'}")
    for name in ("episodes", "frames", "repeats"):
        if getattr(args, name) < 1:
            p.error(f"--{name} must be >= 1")
    return args


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    codec = cast(Codec, args.codec)
    wl = Workload(episodes=args.episodes, frames=args.frames)
    scratch = Path(tempfile.mkdtemp(prefix="openral-bench-", dir=args.tmp))
    offline_in(scratch)

    # Import everything heavy (torch comes with lerobot) before any timing.
    for module in (
        "lerobot.datasets.lerobot_dataset",
        "openral_data.runtime.bridge",
        "openral_data.formats.lerobot_v3",
    ):
        importlib.import_module(module)

    machine = machine_info()
    print(f"scratch: {scratch}")
    print(
        f"machine: {machine['nproc']} cpus ({machine['cpu_model']}), python {machine['python']}, "
        f"av {machine['av_version']}, lerobot {machine['lerobot_version']}, load {machine['loadavg_at_start']}"
    )
    t0 = time.perf_counter()
    data = make_data(wl)
    gen_s = time.perf_counter() - t0
    mb = sum(a.nbytes for ep in data for a in ep.images.values()) / 1e6
    print(f"rendered {wl.total_frames} steps x {len(wl.cameras)} cameras ({mb:.0f} MB) in {gen_s:.1f}s")

    # warm the encoder libraries up once so no contestant pays their first-use cost
    run_pure(
        [EpisodeData({c: a[:4] for c, a in data[0].images.items()}, data[0].states, data[0].actions)],
        scratch / "warmup",
        Workload(episodes=1, frames=4),
        codec,
    )

    KNOBS["encoder_threads"] = args.encoder_threads
    wanted = args.contestants.split(",")
    contestants = [n for n in CONTESTANTS if n in wanted and not (args.no_lerobot and n in LEROBOT)]
    results: dict[str, list[RunResult]] = {n: [] for n in contestants}
    try:
        for rep in range(args.repeats):
            for name in contestants:
                root = scratch / f"rep{rep}" / name
                wall, cpu = timed(name, data, root, wl, codec)
                result = RunResult(wall_s=wall, cpu_s=cpu, video_bytes=video_bytes(root))
                check(name, root, wl, result)
                results[name].append(result)
                print(
                    f"[{rep + 1}/{args.repeats}] {name:<8} {wall:8.2f}s  {wl.total_frames / wall:7.1f} frames/s  "
                    f"video frames {result.video_frames} rows {result.parquet_rows} dropped {result.dropped}"
                )
                if not args.keep:
                    shutil.rmtree(root, ignore_errors=True)
    finally:
        if not args.keep:
            shutil.rmtree(scratch, ignore_errors=True)

    summary = summarize(wl, results)
    print_table(wl, codec, results, summary)
    report = {
        "created": datetime.now(UTC).isoformat(timespec="seconds"),
        "workload": asdict(wl) | {"total_frames": wl.total_frames},
        "codec": codec,
        "pure_encoder": dict(zip(("encoder", "options"), pure_encoder(codec), strict=True)),
        "repeats": args.repeats,
        "order": contestants,
        "machine": machine,
        "frame_generation_s": gen_s,
        "runs": {n: [asdict(r) for r in results[n]] for n in contestants},
        **summary,
        "kept_datasets": str(scratch) if args.keep else None,
    }
    args.out.mkdir(parents=True, exist_ok=True)
    out = args.out / "results.json"
    out.write_text(json.dumps(report, indent=2) + "\n")
    print(f"results: {out}")
    if args.keep:
        print(f"datasets kept in {scratch}")

    ok = all(summary["dropped_frames"][n] == 0 for n in contestants) and summary["ours_loaded_len"] == wl.total_frames
    if not ok:
        print("FAILED: dropped frames or wrong LeRobotDataset length", file=sys.stderr)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
