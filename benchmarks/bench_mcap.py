"""MCAP benchmark: our MCAP sink vs a bare rosbags writer on workload W, and bag -> LeRobot v3 throughput.

Workload W (as in ``bench_writer.py``; its frames rendered by ``workload.py``): 10 episodes x 200 frames at 20 fps,
two RGB cameras 256x256, state float32[8], action float32[7].

Contestants, in this order in every repetition, on the same pre-rendered frames:

1. **bare**: ``rosbags.rosbag2.Writer`` (mcap storage) used directly in one thread: one bag per episode,
   the same topics and message types our sink writes (JointState, 2x CompressedImage JPEG q=90 via Pillow,
   Float32MultiArray, Float32 reward, String task and episode markers), serialised with rosbags' typestore.
   No validation, no thread, no fsync, no staging.
2. **sink**: ``McapSink`` with its defaults (JPEG q=90 in a small encoder pool, writer thread behind a
   bounded queue, per-episode staging + fsync + rename), fed the frames directly as the bare writer is.
3. **bridge+sink**: what ``record --format mcap`` runs: ``DatasetBridge`` (contract checks and a defensive
   copy of every image) -> ``McapSink``.

Outside the timed region every bag of both is read back with rosbags' AnyReader and the messages per topic
are counted against the frames ("dropped"). Then **convert**: our bags -> LeRobot v3 through
``convert_bags`` (mapping inferred from the bags, ``--codec`` as given), reported in frames/s.

Run (from the repository root)::

    .venv/bin/python benchmarks/bench_mcap.py                   # W: 5 rounds, 2 av1 conversions
    .venv/bin/python benchmarks/bench_mcap.py --codec h264      # the conversion with h264
    .venv/bin/python benchmarks/bench_mcap.py --episodes 2 --frames 40 --repeats 1 --convert-repeats 1  # smoke

The machine is shared and noisy: the contestants run back to back in a rotating order, and the ratio
reported is the median of the per-repetition ratios (bare / contestant); median walls and CPU are printed too.
"""

from __future__ import annotations

import argparse
import io
import json
import shutil
import statistics
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np
from PIL import Image as PILImage

sys.path.insert(0, str(Path(__file__).resolve().parent))
from workload import EpisodeData, Workload, bench_schema, feed_bridge, make_data

JPEG_QUALITY = 90


def run_bare(data: list[EpisodeData], root: Path, wl: Workload) -> None:
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_HUMBLE)
    t = store.types
    names = [f"s{i}" for i in range(wl.state_dim)]
    empty = np.zeros(0, np.float64)
    base = time.time_ns()
    for e, ep in enumerate(data):
        with Writer(root / f"episode_{e:06d}", version=8, storage_plugin=StoragePlugin.MCAP) as w:
            c_event = w.add_connection("/openral/episode", "std_msgs/msg/String", typestore=store)
            c_task = w.add_connection("/task", "std_msgs/msg/String", typestore=store)
            c_state = w.add_connection("/joint_states", "sensor_msgs/msg/JointState", typestore=store)
            c_action = w.add_connection("/action", "std_msgs/msg/Float32MultiArray", typestore=store)
            c_reward = w.add_connection("/reward", "std_msgs/msg/Float32", typestore=store)
            c_cams = {
                cam: w.add_connection(f"/camera/{cam}/image/compressed", "sensor_msgs/msg/CompressedImage",
                                      typestore=store)
                for cam in wl.cameras
            }  # fmt: skip
            w.write(c_event, base, store.serialize_cdr(t["std_msgs/msg/String"](data='{"event": "start"}'),
                                                       "std_msgs/msg/String"))  # fmt: skip
            for k in range(wl.frames):
                ns = base + round(k / wl.fps * 1e9)
                stamp = t["builtin_interfaces/msg/Time"](sec=ns // 10**9, nanosec=ns % 10**9)
                if k == 0:
                    w.write(c_task, ns, store.serialize_cdr(t["std_msgs/msg/String"](data=wl.task),
                                                            "std_msgs/msg/String"))  # fmt: skip
                js = t["sensor_msgs/msg/JointState"](
                    header=t["std_msgs/msg/Header"](stamp=stamp, frame_id=""), name=names,
                    position=ep.states[k].astype(np.float64), velocity=empty, effort=empty,
                )  # fmt: skip
                w.write(c_state, ns, store.serialize_cdr(js, "sensor_msgs/msg/JointState"))
                for cam, conn in c_cams.items():
                    buf = io.BytesIO()
                    PILImage.fromarray(ep.images[cam][k], mode="RGB").save(buf, format="JPEG", quality=JPEG_QUALITY)
                    msg = t["sensor_msgs/msg/CompressedImage"](
                        header=t["std_msgs/msg/Header"](stamp=stamp, frame_id=cam), format="jpeg",
                        data=np.frombuffer(buf.getbuffer(), np.uint8),
                    )  # fmt: skip
                    w.write(conn, ns, store.serialize_cdr(msg, "sensor_msgs/msg/CompressedImage"))
                dim = t["std_msgs/msg/MultiArrayDimension"](label="action", size=wl.action_dim, stride=wl.action_dim)
                action = t["std_msgs/msg/Float32MultiArray"](
                    layout=t["std_msgs/msg/MultiArrayLayout"](dim=[dim], data_offset=0), data=ep.actions[k]
                )
                w.write(c_action, ns, store.serialize_cdr(action, "std_msgs/msg/Float32MultiArray"))
                w.write(c_reward, ns, store.serialize_cdr(t["std_msgs/msg/Float32"](data=0.0), "std_msgs/msg/Float32"))
            end = t["std_msgs/msg/String"](data='{"event": "end"}')
            w.write(c_event, ns + 1, store.serialize_cdr(end, "std_msgs/msg/String"))
        base = ns + 10**9


def run_sink(data: list[EpisodeData], root: Path, wl: Workload) -> None:
    """The MCAP sink alone, fed frames directly (as the bare writer is)."""
    from openral_data.formats.mcap import McapSink
    from openral_data.types import EpisodeStart, Frame

    sink = McapSink(root, bench_schema(wl))
    last = wl.frames - 1
    try:
        for seed, ep in enumerate(data):
            sink.begin_episode(EpisodeStart(seed=seed, initial_state={"seed": seed}))
            for k in range(wl.frames):
                sink.add_frame(
                    Frame(
                        state=ep.states[k], action=ep.actions[k], images={cam: ep.images[cam][k] for cam in wl.cameras},
                        task=wl.task, reward=0.0, done=k == last, success=False, timestamp=k / wl.fps,
                    )
                )  # fmt: skip
            sink.end_episode(success=True)
    finally:
        sink.close()


def run_bridge_sink(data: list[EpisodeData], root: Path, wl: Workload) -> None:
    """What `record --format mcap` runs: DatasetBridge (contract checks, defensive copies) -> McapSink."""
    from openral_data.formats.mcap import McapSink

    feed_bridge([McapSink(root, bench_schema(wl))], data, wl)


def count_messages(root: Path) -> dict[str, int]:
    from rosbags.highlevel import AnyReader

    counts: dict[str, int] = {}
    for bag in sorted(root.glob("episode_*")):
        with AnyReader([bag]) as reader:
            for conn, _, raw in reader.messages():
                reader.deserialize(raw, conn.msgtype)
                counts[conn.topic] = counts.get(conn.topic, 0) + 1
    return counts


def _timed(fn: Any, data: list[EpisodeData], root: Path, wl: Workload) -> tuple[float, float]:
    root.mkdir(parents=True)
    t0, c0 = time.perf_counter(), time.process_time()
    fn(data, root, wl)
    return time.perf_counter() - t0, time.process_time() - c0


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--episodes", type=int, default=10)
    p.add_argument("--frames", type=int, default=200)
    p.add_argument("--repeats", type=int, default=5, help="rounds of the three contestants (order rotates)")
    p.add_argument("--convert-repeats", type=int, default=2)
    p.add_argument("--codec", choices=["av1", "h264"], default="av1", help="video codec of the conversion")
    p.add_argument("--out", type=Path, default=Path("benchmarks/results"))
    args = p.parse_args(argv)
    wl = Workload(episodes=args.episodes, frames=args.frames)
    scratch = Path(tempfile.mkdtemp(prefix="openral-bench-mcap-"))
    import openral_data.convert.to_lerobot
    import openral_data.formats.mcap  # noqa: F401
    from openral_data.convert.own_bags import own_mapping
    from openral_data.convert.to_lerobot import convert_bags
    from openral_data.formats.mcap import finished_bags

    t0 = time.perf_counter()
    data = make_data(wl)
    print(f"rendered {wl.total_frames} steps x {len(wl.cameras)} cameras in {time.perf_counter() - t0:.1f}s")
    contestants = {"bare": run_bare, "sink": run_sink, "bridge+sink": run_bridge_sink}
    names = list(contestants)
    runs: dict[str, list[tuple[float, float]]] = {n: [] for n in names}
    ratios: dict[str, list[float]] = {"sink": [], "bridge+sink": []}
    convert_s: list[float] = []
    try:
        for rep in range(args.repeats):
            order = names[rep % 3 :] + names[: rep % 3]  # rotate who goes first
            for name in order:
                root = scratch / f"rep{rep}" / name
                wall, cpu = _timed(contestants[name], data, root, wl)
                counts = count_messages(root)  # outside the timed region: every message deserialised
                frame_topics = [k for k in counts if k.startswith(("/camera", "/joint", "/action"))]
                dropped = sum(wl.total_frames - counts[k] for k in frame_topics)
                assert len(frame_topics) == 2 + len(wl.cameras) and dropped == 0, counts
                runs[name].append((wall, cpu))
                print(f"[{rep + 1}/{args.repeats}] {name:<11} {wall:6.2f}s wall {cpu:6.2f}s cpu "
                      f"{wl.total_frames / wall:7.1f} frames/s  dropped {dropped}")  # fmt: skip
            for name, per_rep in ratios.items():
                per_rep.append(runs["bare"][-1][0] / runs[name][-1][0])
            if rep < args.convert_repeats:
                src = scratch / f"rep{rep}" / "sink"
                t0 = time.perf_counter()
                summary = convert_bags(
                    src, scratch / f"rep{rep}" / "lerobot", own_mapping(finished_bags(src)[0]), codec=args.codec
                )
                convert_s.append(time.perf_counter() - t0)
                assert summary.frames == wl.total_frames, summary.frames
                print(f"[{rep + 1}/{args.repeats}] convert {convert_s[-1]:6.2f}s "
                      f"{wl.total_frames / convert_s[-1]:7.1f} frames/s ({args.codec})")  # fmt: skip
            shutil.rmtree(scratch / f"rep{rep}", ignore_errors=True)
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
    med = {n: (statistics.median(w for w, _ in r), statistics.median(c for _, c in r)) for n, r in runs.items()}
    conv = statistics.median(convert_s) if convert_s else float("nan")
    result: dict[str, Any] = {
        "workload": {"episodes": wl.episodes, "frames": wl.frames, "cameras": list(wl.cameras), "fps": wl.fps},
        "repeats": args.repeats,
        "runs": {n: [{"wall_s": w, "cpu_s": c} for w, c in r] for n, r in runs.items()},
        "pair_ratios_bare_over": ratios,
        "median_pair_ratio_bare_over": {n: statistics.median(r) for n, r in ratios.items()},
        "median_wall_s": {n: m[0] for n, m in med.items()},
        "median_cpu_s": {n: m[1] for n, m in med.items()},
        "convert_s": convert_s,
        "convert_codec": args.codec,
        "convert_frames_per_s": wl.total_frames / conv,
    }
    print("median wall / cpu: " + ", ".join(f"{n} {m[0]:.2f}s / {m[1]:.2f}s" for n, m in med.items()))
    for name, r in ratios.items():
        pairs = ", ".join(f"{x:.2f}" for x in r)
        print(f"{name} vs bare (bare / {name}), median of pairs: {statistics.median(r):.2f}x  (pairs: {pairs})")
    print(f"bag -> LeRobot v3 ({args.codec}): {wl.total_frames / conv:.1f} frames/s (median of {len(convert_s)})")
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / f"mcap_results_{args.codec}.json").write_text(json.dumps(result, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
