"""`replay --mode closed-loop --save-video / --view`: the rebuilt scene's rollouts are shown to the same observers
`record` uses, with or without `--record`; the other modes refuse the options in one line."""

from __future__ import annotations

import re
import subprocess
from dataclasses import replace
from pathlib import Path
from urllib.parse import quote

import pytest

from openral_data.errors import OutputExists
from openral_data.replay import ReplayOptions, replay
from openral_data.replay.outcome import EpisodeOutcome
from tests.support.cli import run_cli
from tests.support.debug_video import check_mock_video, leftovers
from tests.support.live import connect_client, entities, free_port_pair, settled, stop_rerun
from tests.support.replay import record_mock

pytestmark = pytest.mark.filterwarnings("ignore:RRD file has no footer")


@pytest.mark.slow
def test_closed_loop_save_video_writes_one_mp4_per_replayed_episode(project: Path, tmp_path: Path) -> None:
    dataset = record_mock(project, tmp_path / "mock").out
    base = ReplayOptions(dataset, mode="closed-loop", rskill="random-mock", episodes="0,2", max_steps=7)

    # without --record: `<results>.debug/`, nothing else written beside the results
    res = tmp_path / "res"
    done = replay(replace(base, out=res, save_video=True))
    videos = tmp_path / "res.debug"
    assert sorted(p.name for p in videos.iterdir()) == ["episode_000000.mp4", "episode_000002.mp4"]
    assert [o.index for o in done.episodes] == [0, 2] and all(o.steps > 0 for o in done.episodes)
    for o in done.episodes:  # one frame per step run, the mock's colours of the replayed episode
        check_mock_video(videos / f"episode_{o.index:06d}.mp4", o.index, o.steps)
    assert ("debug videos", str(videos)) in done.rows()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["mock", "project", "res", "res.debug"]

    # with --record and --save-video-dir: the same rollouts, numbered as the episodes of the new dataset
    again, chosen = tmp_path / "again", tmp_path / "chosen"
    both = replay(replace(base, out=tmp_path / "res2", record=again, codec="h264", save_video_dir=chosen))
    assert [o.steps for o in both.episodes] == [o.steps for o in done.episodes]
    assert sorted(p.name for p in chosen.iterdir()) == ["episode_000000.mp4", "episode_000001.mp4"]
    for k, o in enumerate(both.episodes):
        check_mock_video(chosen / f"episode_{k:06d}.mp4", o.index, o.steps)
    assert leftovers(chosen) == []
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    ds = LeRobotDataset("local/again", root=again, video_backend="pyav")
    assert [int(n) for n in ds.meta.episodes["length"]] == [o.steps for o in both.episodes] and len(ds) > 0

    # videos already there are never overwritten: refused before the replay runs
    canary = (videos / "episode_000000.mp4").read_bytes()
    with pytest.raises(OutputExists, match="already holds debug videos") as info:
        replay(replace(base, out=tmp_path / "res3", save_video_dir=videos))
    assert info.value.code == "output.exists"
    assert (videos / "episode_000000.mp4").read_bytes() == canary and not (tmp_path / "res3").exists()


@pytest.mark.slow
def test_closed_loop_view_serves_a_stream_a_client_receives(
    project: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    dataset = record_mock(project, tmp_path / "mock").out
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    port = free_port_pair()
    url = f"rerun+http://127.0.0.1:{port}/proxy"
    got = tmp_path / "client.rrd"
    client: list[subprocess.Popen[bytes]] = []

    def progress(outcome: EpisodeOutcome | None, done: int, total: int) -> None:
        if outcome is None or client:
            return
        # after the first episode: a client connects to the served stream and saves what it receives
        client.append(connect_client(url, got))

    opts = ReplayOptions(
        dataset, mode="closed-loop", rskill="random-mock", episodes="0,1", out=tmp_path / "res", view=True
    )
    summary = replay(replace(opts, view_port=port), progress)
    assert client
    settled(got)
    stop_rerun(client[0])
    lines = capsys.readouterr().err.splitlines()
    assert f"view: open http://127.0.0.1:{port + 1}/?url={quote(url, safe='')} (or: rerun --connect {url})" in lines
    shown = [m for line in lines if (m := re.fullmatch(r"view: (\d+) frames shown, (\d+) dropped.*", line))]
    steps = sum(o.steps for o in summary.episodes)
    assert len(shown) == 1 and int(shown[0][1]) + int(shown[0][2]) == steps

    received = {rid: v for rid, v in entities(got).items() if "-episode-" in rid}
    assert sorted(rid.rsplit("-", 1)[1] for rid in received) == ["0", "1"]
    for rid, (temporal, static) in received.items():
        n = temporal["/outcome/reward"]
        # the pictures at most 10 a second: every other frame of the 20 fps episode, the first included
        assert n > 0 and temporal["/cameras/wrist"] == temporal["/cameras/front"] == (n + 1) // 2, rid
        assert any(e.startswith("/state/") for e in temporal) and any(e.startswith("/action/") for e in temporal)
        assert temporal["/events"] == 1 and "/task" in static
    assert sum(v[0]["/outcome/reward"] for v in received.values()) == int(shown[0][1])


@pytest.mark.parametrize(
    ("args", "first"),
    [
        (["--mode", "actions", "--save-video"], "error: --save-video, --view: only with --mode closed-loop"),
        (["--mode", "actions", "--view"], "error: --save-video, --view: only with --mode closed-loop"),
        (["--view-port", "9876"], "error: --save-video, --view: only with --mode closed-loop"),  # given, if default
        (
            ["--mode", "policy", "--rskill", "recorded", "--save-video-dir", "v"],
            "error: --save-video, --view: only with --mode closed-loop",
        ),
    ],
)
def test_the_options_are_refused_where_no_scene_is_shown(
    project: Path, tmp_path: Path, args: list[str], first: str
) -> None:
    dataset = record_mock(project, tmp_path / "mock").out
    out = tmp_path / "res"
    proc = run_cli("replay", str(dataset), *args, "--out", str(out))
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr.splitlines()[0].startswith(first), proc.stderr
    assert not out.exists() and not (tmp_path / "res.debug").exists() and not (tmp_path / "v").exists()
