"""`view --serve`: one episode kept in rerun's web viewer for as long as the process runs. The episode is logged
(as `view` logs it, `rerun_view.log_episode`) into a recording that serves itself over gRPC
(`RecordingStream.serve_grpc`, which keeps what was logged for viewers that connect later), and rerun's own web
viewer, the one bundled in the rerun wheel (no internet), is served over HTTP (`rr.serve_web_viewer`). The
page's URL names the gRPC address (`?url=`), so opening it shows the episode; `browse --rerun-url` links there.
Both servers live in rerun's threads and stop with the process."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import rerun as rr

from openral_data.metrics.sources import open_dataset
from openral_data.viz import DEFAULT_PORT
from openral_data.viz.entities import APP_ID
from openral_data.viz.live import check_port, page_url
from openral_data.viz.rerun_view import load_episode, log_episode

WEB_PORT = 9090  # rerun's default for its web viewer


@dataclass
class Served:
    """What `serve_episode` started: the recording (kept: it owns the gRPC server) and the viewer's URL."""

    recording: rr.RecordingStream
    url: str
    frames: int


def serve_episode(
    dataset: Path, episode: int, results: Path | None = None, web_port: int = WEB_PORT, grpc_port: int = DEFAULT_PORT
) -> Served:
    """Log episode `episode` of `dataset` and serve it with the web viewer; every input is checked (the dataset,
    the episode, both ports free) before anything is served."""
    data = load_episode(open_dataset(dataset), episode, results)
    check_port(web_port, "--web-port")
    check_port(grpc_port, "--grpc-port")
    rec = rr.RecordingStream(APP_ID, recording_id=f"{dataset.name}-episode-{episode}")
    grpc = rec.serve_grpc(grpc_port=grpc_port)
    log_episode(rec, data)
    rec.flush()
    rr.serve_web_viewer(web_port=web_port, open_browser=False, connect_to=grpc)
    return Served(rec, page_url(web_port, grpc), data.frames.num_rows)
