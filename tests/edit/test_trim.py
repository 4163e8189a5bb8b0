"""`episodes trim`: frames dropped inside episodes, `--idle` (the idle heads and tails `quality` measures, an
idle head of known length) or `--frames EP:START-END` (END included). Every output frame is the source frame it
came from (state, action, task; pixels exactly where packets were copied, within codec loss where the episode's
camera was re-encoded), later frames and episodes renumbered, untouched episodes' rows and packets unchanged,
`doctor --deep` clean, lerobot 0.6.1 loads the result; on our recordings and on datasets lerobot wrote."""

from __future__ import annotations

import shutil
from pathlib import Path
from typing import Any

import av
import numpy as np
import pyarrow.parquet as pq
import pytest

from openral_data.doctor import check
from openral_data.edit.cut import plan, runs, splice
from openral_data.edit.recode import CameraEncoders
from openral_data.edit.trim import parse_frames, trim
from openral_data.errors import DatasetBusy, EpisodeSelectionError
from openral_data.formats.lerobot_v3.encoder import VideoSettings
from openral_data.formats.lerobot_v3.lock import DatasetLock
from openral_data.types import CameraShape
from tests.support import quality as q
from tests.support.inproc import run_inproc
from tests.support.lerobot_written import IMAGE_CAMERA, LENGTHS, digest, loaded_episodes, write_lerobot_dataset

N = 24
EPISODES = ["head7", "clean", "head8", "short"]  # idle heads of 7 and 8 frames; `short` keeps 5 after its head
IDLE = {"head7": 7, "head8": 8, "short": 19}
KEY = "observation.images.cam"


def _episodes() -> list[q.Episode]:
    out = []
    for seed, name in enumerate(EPISODES):
        ep = q.moving(N, seed)
        k = IDLE.get(name, 0)
        if k:  # frames 0..k-1 hold frame k-1's values; frame k moves
            ep.state[:k] = ep.state[k - 1]
            ep.action[:k] = ep.action[k - 1]
        out.append(ep)
    return out


@pytest.fixture(scope="module")
def ours(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return q.write(tmp_path_factory.mktemp("trim") / "ds", _episodes())


@pytest.fixture(scope="module")
def theirs(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("trim-lerobot") / "ds"
    write_lerobot_dataset(root, with_success=True, image_camera=True, environment_state=True)
    return root


def _rows(root: Path) -> list[dict[str, Any]]:
    files = sorted((root / "data").glob("*/*.parquet"))
    rows = [r for f in files for r in pq.read_table(f).to_pylist()]
    return sorted(rows, key=lambda r: int(r["index"]))


def _episode_rows(root: Path) -> list[dict[str, Any]]:
    return pq.read_table(root / "meta/episodes").to_pylist()


def _packets(root: Path, episode: int) -> list[bytes]:
    """The packets of one episode's video (by its from/to timestamps in meta/episodes)."""
    row = _episode_rows(root)[episode]
    path = root / "videos" / KEY / f"chunk-{row[f'videos/{KEY}/chunk_index']:03d}"
    path = path / f"file-{row[f'videos/{KEY}/file_index']:03d}.mp4"
    lo, hi = row[f"videos/{KEY}/from_timestamp"], row[f"videos/{KEY}/to_timestamp"]
    with av.open(str(path)) as c:
        s = c.streams.video[0]
        assert s.time_base is not None
        tb = s.time_base
        packets = [p for p in c.demux(s) if p.size and p.pts is not None]
        out = [bytes(p) for p in packets if p.pts is not None and lo - 1e-6 <= p.pts * tb < hi - 1e-6]
    return out


def _same_frame(got: dict[str, Any], want: dict[str, Any], exact: bool) -> None:
    assert got["state"] == want["state"] and got["action"] == want["action"] and got["task"] == want["task"]
    assert got["env"] == want["env"]  # a carried column (lerobot's environment state), or None in both
    assert (got["wrist"] is None and want["wrist"] is None) or np.array_equal(got["wrist"], want["wrist"])
    if exact:
        assert np.array_equal(got["cam"], want["cam"])
    else:
        assert float(np.abs(got["cam"] - want["cam"]).mean()) < 0.06


def edited(src: Path, out: Path, *args: str) -> str:
    """`openral-data ARGS` succeeded, left `src` byte-unchanged and wrote `out`, healthy to `doctor --deep`; its
    stdout."""
    before = digest(src)
    res = run_inproc(*args)
    assert res.returncode == 0, res.stderr
    assert digest(src) == before
    assert check(out, deep=True) == []
    return res.stdout


# -- the parts that need no dataset ------------------------------------------------------------------------------
def test_frames_are_parsed_end_included_and_refused_in_one_line() -> None:
    assert parse_frames("0:0-4, 2:20,2:10-12", [10, 5, 30]) == {0: [(0, 5)], 2: [(10, 13), (20, 21)]}
    cases = {
        "0:5:": ("episodes.syntax", "--frames: '0:5:' is not EPISODE:START-END or EPISODE:FRAME"),
        "x": ("episodes.syntax", "--frames: 'x' is not EPISODE:START-END or EPISODE:FRAME"),
        "3:0-1": ("episodes.range", "--frames: '3:0-1': episode 3 is outside the dataset's episodes 0..2"),
        "1:2-5": ("episodes.range", "--frames: '1:2-5': frames 2-5 are outside episode 1's frames 0..4"),
        "0:4-2": ("episodes.range", "--frames: '0:4-2': frames 4-2 are outside episode 0's frames 0..9"),
        "2:0-4,2:3-6": ("episodes.overlap", "--frames: episode 2: frames 0-4 and 3-6 overlap"),
        "1:0-2,1:3-4": (
            "episodes.empty",
            "--frames: every frame of episode 1 would be dropped; use episodes delete --episodes 1",
        ),
    }
    for text, (code, message) in cases.items():
        with pytest.raises(EpisodeSelectionError) as err:
            parse_frames(text, [10, 5, 30])
        assert (err.value.code, str(err.value)) == (code, message), text


def test_runs_and_when_packets_can_be_copied() -> None:
    assert runs([0, 1, 2, 5, 6]) == [(0, 3), (5, 7)]
    key = [True, False, True, False, True, False]
    assert plan([2, 3], key) == [(True, 2, 4)] and plan([0, 1, 4, 5], key) == [(True, 0, 2), (True, 4, 6)]
    # the groups of pictures inside a run are copied, the frames before its first / from its last keyframe not
    assert plan([1, 2, 3, 4, 5], key) == [(False, 1, 2), (True, 2, 6)]
    assert plan([1, 2, 3, 4], key) == [(False, 1, 2), (True, 2, 4), (False, 4, 5)]
    assert plan([0, 1, 2, 3, 4], key) == [(True, 0, 4), (False, 4, 5)]
    assert plan([1, 2], key) == [(False, 1, 3)]  # no whole group of pictures: encoded as a whole


def test_a_splice_whose_codec_headers_differ_is_refused() -> None:
    shape = CameraShape(32, 32)
    frames = [np.full((32, 32, 3), 20 * t, np.uint8) for t in range(4)]
    clips = {}
    for codec in ("av1", "h264"):
        enc = CameraEncoders({"cam": shape}, VideoSettings(codec=codec), fps=10)
        clips[codec] = enc.encode({"cam": iter(frames)}, 4, "test")["cam"].data
        enc.close()
    segments = [(True, 0, 2), (False, 2, 3)]
    assert splice(clips["av1"], segments, [clips["h264"]], 10, "test") is None
    assert splice(clips["av1"], segments, [clips["av1"]], 10, "test") is not None


# -- our recordings -----------------------------------------------------------------------------------------------
@pytest.mark.slow
def test_idle_heads_are_trimmed_frame_exact(ours: Path, tmp_path: Path) -> None:
    out = tmp_path / "out"
    said = edited(ours, out, "episodes", "trim", str(ours), "--idle", "--min-frames", "6", "--out", str(out))
    assert "2 episodes, 15 frames dropped" in said
    # head 8 starts on a keyframe (g=2): packets copied; head 7 does not: its frame 7 is encoded again, alone
    assert "camera clips: 1 cut by copying packets, 1 re-encoded at a cut only, 0 re-encoded\n" in said
    lengths = [r["length"] for r in _episode_rows(out)]
    assert lengths == [N - 7, N, N - 8, N]  # `short` would keep 5 < --min-frames 6: kept whole
    src, got = loaded_episodes(ours), loaded_episodes(out)
    for e, name in enumerate(EPISODES):
        k = 0 if name == "short" else IDLE.get(name, 0)
        for t, frame in enumerate(got[e]):
            _same_frame(frame, src[e][t + k], exact=(name, t) != ("head7", 0))
    rows, old = _rows(out), _rows(ours)
    assert [r["index"] for r in rows] == list(range(sum(lengths)))
    assert [r["timestamp"] for r in rows if r["episode_index"] == 2] == pytest.approx([t / q.FPS for t in range(N - 8)])
    # an untouched episode: rows unchanged but for `index`, packets byte-identical
    drop = {"index"}
    same = [{k: v for k, v in r.items() if k not in drop} for r in old if r["episode_index"] == 1]
    assert [{k: v for k, v in r.items() if k not in drop} for r in rows if r["episode_index"] == 1] == same
    assert _packets(out, 1) == _packets(ours, 1)
    assert _packets(out, 2) == _packets(ours, 2)[8:]  # copied from the keyframe on
    assert _packets(out, 0)[1:] == _packets(ours, 0)[8:]  # frame 7 encoded again, from frame 8 on copied
    # the trimmed episode's last frame still ends it
    assert [r["next.done"] for r in rows if r["episode_index"] == 0][-1] is True


@pytest.mark.slow
def test_frames_in_place_and_a_busy_dataset_is_refused(
    ours: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    src = tmp_path / "copy"
    shutil.copytree(ours, src)
    with DatasetLock(src, "test"), pytest.raises(DatasetBusy):
        trim(src, "1:0-3", in_place=True)
    res = run_inproc("episodes", "trim", str(src), "--frames", "1:0-3,1:20-23,3:10", "--in-place")
    assert res.returncode == 0, res.stderr
    assert [r["length"] for r in _episode_rows(src)] == [N, N - 8, N, N - 1]
    assert check(src, deep=True) == []
    # --idle reads the quality table `quality` cached rather than measuring again
    assert run_inproc("quality", str(src)).returncode == 0
    monkeypatch.setattr("openral_data.edit.trim.motion_pass", _not_called)
    out = tmp_path / "idle"
    res = run_inproc("episodes", "trim", str(src), "--idle", "--min-frames", "6", "--out", str(out))
    assert res.returncode == 0, res.stderr
    assert [r["length"] for r in _episode_rows(out)] == [N - 7, N - 8, N - 8, N - 1]


def _not_called(*_: object) -> None:
    raise AssertionError("measured again")


def test_bad_requests_are_one_line_and_write_nothing(ours: Path, tmp_path: Path) -> None:
    out = tmp_path / "out"
    for args, message in (
        (["--frames", "9:0-1"], "error: --frames: '9:0-1': episode 9 is outside the dataset's episodes 0..3"),
        (["--frames", "0:0-3,0:2-5"], "error: --frames: episode 0: frames 0-3 and 2-5 overlap"),
        (["--frames", "0:20-24"], "error: --frames: '0:20-24': frames 20-24 are outside episode 0's frames 0..23"),
        (["--frames", "0:1-2", "--idle"], "error: --frames: give either --frames EP:START-END,... or --idle"),
        ([], "error: --frames: give either --frames EP:START-END,... or --idle"),
        (["--idle", "--min-frames", "0"], "error: --min-frames: 0 is not a positive number of frames"),
    ):
        res = run_inproc("episodes", "trim", str(ours), *args, "--out", str(out))
        assert (res.returncode, res.stderr.strip()) == (2, message), args
        assert not out.exists()


# -- datasets lerobot wrote -----------------------------------------------------------------------------------------
@pytest.mark.slow
def test_a_lerobot_dataset_is_trimmed_frame_exact(theirs: Path, tmp_path: Path) -> None:
    out = tmp_path / "out"
    said = edited(theirs, out, "episodes", "trim", str(theirs), "--frames", "0:0-1,1:3,1:8", "--out", str(out))
    # lerobot's h264 here: frames 0..7 of episode 1 are keyframes, frame 8 is not, so the run 4..7 ends inside
    # a group of pictures: frame 7 is encoded again, frames 4..6 copied
    assert "camera clips: 1 cut by copying packets, 1 re-encoded at a cut only, 0 re-encoded\n" in said
    keep = {0: list(range(2, LENGTHS[0])), 1: [0, 1, 2, 4, 5, 6, 7], 2: list(range(LENGTHS[2]))}
    src, got = loaded_episodes(theirs), loaded_episodes(out)
    assert [len(g) for g in got] == [len(k) for k in keep.values()]
    for e, frames in keep.items():
        for t, k in enumerate(frames):
            _same_frame(got[e][t], src[e][k], exact=(e, k) != (1, 7))
    assert [f["success"] for f in got[0]] == [False] * 3 + [True]  # the last frame of a success still says so
    assert not any(f["success"] for f in got[1])
    # every feature's statistics of a trimmed episode count its kept frames (the image column's recomputed)
    meta = _episode_rows(out)
    for key in (KEY, IMAGE_CAMERA, "observation.state", "observation.environment_state"):
        assert [int(np.ravel(r[f"stats/{key}/count"])[0]) for r in meta] == [4, 7, LENGTHS[2]], key
