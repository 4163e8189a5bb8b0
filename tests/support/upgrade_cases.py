"""The v2.x datasets `upgrade` is tested on: `legacy_v2.write_v2`'s, and variants of them that lerobot 0.6.1's
own converter gets wrong (each edits a written dataset the way such datasets occur on people's disks and the
Hub); `reference` runs lerobot's converter itself on a copy; `old_frames` reads what OLD holds, frame by frame,
as lerobot's loader returns frames (`lerobot_written.loaded_episodes`' shape), for frame-exact comparisons."""

from __future__ import annotations

import json
import shutil
from pathlib import Path
from typing import Any

import av
import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

from tests.support.legacy_v2 import IMAGE_CAMERA, VIDEO_CAMERA, write_v2

CAMERAS = (VIDEO_CAMERA, IMAGE_CAMERA)
Frame = dict[str, Any]


def _edit_json(path: Path, edit: Any) -> None:
    doc = json.loads(path.read_text())
    edit(doc)
    path.write_text(json.dumps(doc, indent=4))


def _edit_lines(path: Path, edit: Any) -> None:
    rows = [json.loads(line) for line in path.read_text().splitlines() if line.strip()]
    for row in rows:
        edit(row)
    path.write_text("".join(json.dumps(r) + "\n" for r in rows))


def camera_names_null(root: Path) -> None:
    """Cameras with `names: null` (lerobot issue #3786: kept so by its converter; the loader indexes names[2])."""

    def edit(info: dict[str, Any]) -> None:
        for key in CAMERAS:
            if key in info["features"]:
                info["features"][key]["names"] = None

    _edit_json(root / "meta/info.json", edit)


def without_camera_stats(root: Path) -> None:
    """episodes_stats.jsonl without the cameras (#3786: the converted stats.json then lacks them)."""
    _edit_lines(root / "meta/episodes_stats.jsonl", lambda row: [row["stats"].pop(k, None) for k in CAMERAS])


def flat_camera_stats(root: Path) -> None:
    """Camera statistics stored one value per channel ([r, g, b]) instead of lerobot's (3, 1, 1)."""

    def edit(row: dict[str, Any]) -> None:
        for key in CAMERAS & row["stats"].keys():
            row["stats"][key] = {
                k: v if k == "count" else np.asarray(v).reshape(-1).tolist() for k, v in row["stats"][key].items()
            }

    _edit_lines(root / "meta/episodes_stats.jsonl", edit)


def without_info_keys(root: Path, *keys: str) -> None:
    """info.json without keys lerobot's `convert_info` indexes (`total_chunks`, `total_videos`: KeyError)."""
    _edit_json(root / "meta/info.json", lambda info: [info.pop(k, None) for k in keys])


def stale_counts(root: Path) -> None:
    """info.json's totals and episode 0's `length` in episodes.jsonl off by some (hand-edited datasets)."""

    def info(doc: dict[str, Any]) -> None:
        doc["total_frames"] += 7
        doc["total_episodes"] += 1

    _edit_json(root / "meta/info.json", info)
    _edit_lines(
        root / "meta/episodes.jsonl",
        lambda row: row.update(length=row["length"] + 2) if row["episode_index"] == 0 else None,
    )


def apple_double(root: Path) -> None:
    """macOS `._NAME` resource-fork files beside the episodes' files (copied off a Mac): lerobot's globs take them."""
    for pattern in ("data/*/*.parquet", "videos/*/*/*.mp4"):
        for path in sorted(root.glob(pattern)):
            path.with_name("._" + path.name).write_bytes(b"\x00\x05\x16\x07" + bytes(80))
            break


def subset(root: Path) -> None:
    """Episode 0 deleted (files and lines; info.json's totals left stale): episodes 1 and 2 remain, their `index`
    starting at 5 (a subset kept from a larger dataset, like the real G1 fixture whose only episode is 29)."""
    for path in (*root.glob("data/*/episode_000000.parquet"), *root.glob("videos/*/*/episode_000000.mp4")):
        path.unlink()
    for name in ("episodes.jsonl", "episodes_stats.jsonl"):
        path = root / "meta" / name
        path.write_text("".join(line + "\n" for line in path.read_text().splitlines()[1:]))


def wallclock(root: Path) -> None:
    """Wall-clock timestamps (jitter of a few ms to 30 ms on t / fps), the video still on the t / fps grid, like
    the real CR5 fixture: lerobot's converter converts it and its loader then raises FrameTimestampError."""
    for path in sorted(root.glob("data/*/*.parquet")):
        table = pq.read_table(path)
        ts = np.asarray(table.column("timestamp").to_numpy(), np.float64)
        jitter = 0.0313 + 0.007 * np.arange(len(ts)) % 0.02
        i = table.schema.get_field_index("timestamp")
        table = table.set_column(i, table.schema.field(i), pa.array((ts + jitter).astype(np.float32)))
        pq.write_table(table, path)


def custom_script(root: Path) -> None:
    """A v2.1 dataset as its authors' own recording script wrote it (issue #45, item 6): wall-clock timestamps
    (`wallclock`), no `index`/`task_index` (neither columns nor features), `{chunk_index}` in the path templates,
    and every video re-encoded as MPEG-4 part 2 ("mp4v"). lerobot's converter converts it; its loader then fails."""
    wallclock(root)
    for path in sorted(root.glob("data/*/*.parquet")):
        pq.write_table(pq.read_table(path).drop_columns(["index", "task_index"]).replace_schema_metadata(None), path)

    def info(doc: dict[str, Any]) -> None:
        for key in ("index", "task_index"):
            del doc["features"][key]
        for name in ("data_path", "video_path"):
            doc[name] = doc[name].replace("{episode_chunk", "{chunk_index")
        for ft in doc["features"].values():
            if ft["dtype"] == "video":
                ft["info"]["video.codec"] = "mp4v"

    _edit_json(root / "meta/info.json", info)
    for path in sorted(root.glob("videos/*/*/*.mp4")):
        _as_mp4v(path, int(json.loads((root / "meta/info.json").read_text())["fps"]))


def _as_mp4v(path: Path, fps: int) -> None:
    from fractions import Fraction

    with av.open(str(path)) as src:
        frames = [f.to_ndarray(format="rgb24") for f in src.decode(video=0)]
    with av.open(str(path), "w", format="mp4") as out:
        stream = out.add_stream("mpeg4", rate=fps)
        stream.height, stream.width = frames[0].shape[:2]
        stream.pix_fmt = "yuv420p"
        stream.codec_context.time_base = Fraction(1, fps)
        stream.options = {"qscale": "1"}
        for t, pixels in enumerate(frames):
            frame = av.VideoFrame.from_ndarray(pixels, format="rgb24")
            frame.pts = t
            out.mux(stream.encode(frame))
        out.mux(stream.encode(None))


def written(root: Path, variant: str = "", **kw: Any) -> Path:
    """`write_v2(root, **kw)` then the named variant's edit."""
    write_v2(root, **kw)
    edits = {
        "": lambda r: None,
        "camera_names_null": camera_names_null,
        "without_camera_stats": without_camera_stats,
        "flat_camera_stats": flat_camera_stats,
        "without_info_keys": lambda r: without_info_keys(r, "total_chunks", "total_videos"),
        "stale_counts": stale_counts,
        "apple_double": apple_double,
        "subset": subset,
        "wallclock": wallclock,
        "custom_script": custom_script,
    }
    edits[variant](root)
    return root


def reference(old: Path, work: Path) -> Path:
    """lerobot 0.6.1's own `convert_dataset` (local root, no push: no network) run on a copy of `old`; returns the
    converted dataset (lerobot moves it into the copy's place)."""
    from lerobot.scripts.convert_dataset_v21_to_v30 import convert_dataset

    copy = work / "lerobot-converted"
    shutil.copytree(old, copy)
    convert_dataset("local/reference", root=copy, push_to_hub=False)
    return copy


def old_frames(root: Path) -> list[list[Frame]]:
    """What v2.x dataset `root` holds, per episode: state, action, task and the cameras as lerobot returns them
    (CHW float32 in [0, 1]; the video decoded from OLD's own mp4 with PyAV, as lerobot's pyav backend does)."""
    info = json.loads((root / "meta/info.json").read_text())
    tasks = {r["task_index"]: r["task"] for r in map(json.loads, (root / "meta/tasks.jsonl").read_text().splitlines())}
    episodes = {
        (row := json.loads(line))["episode_index"]: row
        for line in (root / "meta/episodes.jsonl").read_text().splitlines()
    }
    out: list[list[Frame]] = []
    for e in sorted(episodes):
        chunk = e // info["chunks_size"]
        fmt = {"episode_chunk": chunk, "chunk_index": chunk, "episode_index": e, "video_key": VIDEO_CAMERA}
        table = pq.read_table(root / info["data_path"].format(**fmt)).to_pylist()
        cams: list[Any] = [None] * len(table)
        if VIDEO_CAMERA in info["features"]:
            with av.open(str(root / info["video_path"].format(**fmt))) as video:
                cams = [_chw(f.to_ndarray(format="rgb24")) for f in video.decode(video=0)]
        task = episodes[e]["tasks"][0]  # the frames' own task_index wins (`custom_script` has none)
        out.append([_frame(row, cams[t], tasks, task) for t, row in enumerate(table)])
    return out


def _frame(row: dict[str, Any], cam: Any, tasks: dict[int, str], task: str) -> Frame:
    from io import BytesIO

    from PIL import Image

    wrist = row.get(IMAGE_CAMERA)
    return {
        "state": np.asarray(row["observation.state"], np.float32).tolist(),
        "action": np.asarray(row["action"], np.float32).tolist(),
        "cam": cam,
        "wrist": None if wrist is None else _chw(np.asarray(Image.open(BytesIO(wrist["bytes"])).convert("RGB"))),
        "task": tasks[row["task_index"]] if "task_index" in row else task,
        "success": None,
        "env": None,
    }


def _chw(pixels: Any) -> Any:
    return (np.asarray(pixels, np.float32) / 255.0).transpose(2, 0, 1)


def assert_loads_like_old(old: Path, new: Path, every: int = 1) -> int:
    """lerobot's loader on NEW gives OLD's frames: every numeric feature of every frame equal, the task, and (for
    every `every`-th frame and the last of each episode) each video camera's pixels equal to OLD's own mp4
    decoded; episodes numbered 0..n-1 in OLD's order, timestamps t / fps. Returns the frames compared."""
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    ds = LeRobotDataset("local/check", root=new, video_backend="pyav")
    info = json.loads((old / "meta/info.json").read_text())
    feats = info["features"]
    skip = ("episode_index", "index", "timestamp", "frame_index")  # renumbered / put on the grid: checked below
    numeric = [k for k, ft in feats.items() if ft["dtype"] not in ("video", "image", "string") and k not in skip]
    videos = [k for k, ft in feats.items() if ft["dtype"] == "video"]
    tasks = {r["task_index"]: r["task"] for r in map(json.loads, (old / "meta/tasks.jsonl").read_text().splitlines())}
    numbers = sorted(
        json.loads(line)["episode_index"] for line in (old / "meta/episodes.jsonl").read_text().splitlines()
    )
    i = 0
    for e, number in enumerate(numbers):
        fmt = {"episode_chunk": number // info["chunks_size"], "episode_index": number}
        rows = pq.read_table(old / info["data_path"].format(**fmt)).to_pylist()
        pixels = {}
        for key in videos:
            with av.open(str(old / info["video_path"].format(**fmt, video_key=key))) as video:
                pixels[key] = [_chw(f.to_ndarray(format="rgb24")) for f in video.decode(video=0)]
        for t, row in enumerate(rows):
            item = ds[i] if t % every == 0 or t == len(rows) - 1 else ds.hf_dataset[i]
            assert (int(item["episode_index"]), int(item["frame_index"]), int(item["index"])) == (e, t, i)
            assert abs(float(item["timestamp"]) - t / info["fps"]) < 1e-4
            for key in numeric:
                want = np.asarray(row[key], np.dtype(feats[key]["dtype"])).reshape(-1)
                assert np.array_equal(np.asarray(item[key]).reshape(-1), want), (key, e, t)
            assert tasks[row["task_index"]] == (item["task"] if "task" in item else tasks[int(item["task_index"])])
            for key in (k for k in videos if k in item):
                assert np.array_equal(item[key].numpy(), pixels[key][t]), (key, e, t)
            i += 1
    assert i == len(ds)
    return i


def renumber(root: Path, numbers: dict[int, int]) -> Path:
    """v2.x dataset `root`'s episodes numbered anew, old -> new (files renamed, `episode_index` in the data and the
    jsonl meta rewritten; `index` kept), as a subset kept from a larger dataset is: the real G1 fixture's only
    episode is 29."""
    info = json.loads((root / "meta/info.json").read_text())
    videos = [k for k, ft in info["features"].items() if ft["dtype"] == "video"]
    for old, new in sorted(numbers.items(), key=lambda p: -p[1]):  # highest first: no rename onto a pending one
        for key in [None, *videos]:
            template = info["data_path"] if key is None else info["video_path"]
            src, dst = (
                root / template.format(episode_chunk=n // info["chunks_size"], episode_index=n, video_key=key)
                for n in (old, new)
            )
            dst.parent.mkdir(parents=True, exist_ok=True)
            if key is not None:
                src.rename(dst)
                continue
            table = pq.read_table(src)
            i = table.schema.get_field_index("episode_index")
            src.unlink()
            column = pa.array([new] * table.num_rows, table.schema.field(i).type)
            pq.write_table(table.set_column(i, table.schema.field(i), column), dst)
    for name in ("episodes.jsonl", "episodes_stats.jsonl"):
        if (root / "meta" / name).is_file():
            _edit_lines(root / "meta" / name, lambda row: row.update(episode_index=numbers[row["episode_index"]]))
    return root
