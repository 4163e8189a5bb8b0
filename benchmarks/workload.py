"""Workload W of the writer benchmarks, rendered once before anything is timed: its episodes' frames, states and
actions (`make_data`), its dataset schema (`bench_schema`) and how `record` feeds it to sinks (`feed_bridge`).

W (the defaults): 10 episodes x 200 frames at 20 fps, two RGB cameras (``front``, ``wrist``) of 256x256,
``observation.state`` float32[8], ``action`` float32[7]. The frames are a smooth textured background (a wall and a
table) with a few moving, shaded objects whose positions depend on (episode, step, camera); the wrist camera also
pans. Used by bench_writer.py, bench_cli_writer.py, bench_mcap.py and bench_convert.py.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from typing import Any, Literal

# SVT-AV1 prints a banner to stderr for every encoder it opens unless told otherwise; set it before any
# encoder exists so all three contestants run with the same setting.
os.environ.setdefault("SVT_LOG", "1")

import numpy as np
import numpy.typing as npt

Codec = Literal["av1", "h264"]
ImageArray = npt.NDArray[np.uint8]
FloatArray = npt.NDArray[np.float32]


# -- workload ----------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Workload:
    episodes: int = 10
    frames: int = 200
    cameras: tuple[str, ...] = ("front", "wrist")
    height: int = 256
    width: int = 256
    state_dim: int = 8
    action_dim: int = 7
    fps: int = 20
    task: str = "bench task"

    @property
    def total_frames(self) -> int:
        return self.episodes * self.frames


@dataclass
class EpisodeData:
    images: dict[str, ImageArray]  # camera -> uint8[frames, H, W, 3]
    states: FloatArray  # float32[frames, state_dim]
    actions: FloatArray  # float32[frames, action_dim]


# -- frame rendering ---------------------------------------------------------------------------------------
_PAN_MARGIN = 32  # the wrist camera pans over a background this much larger than the frame on each side


def _box_blur(x: FloatArray, passes: int = 2) -> FloatArray:
    """3x3 box blur (wrapping at the borders), `passes` times."""
    for _ in range(passes):
        acc = np.zeros_like(x)
        for dy in (-1, 0, 1):
            for dx in (-1, 0, 1):
                acc += np.roll(x, (dy, dx), axis=(0, 1))
        x = (acc / 9).astype(np.float32)
    return x


def _background(cam: int, wl: Workload) -> FloatArray:
    """A wall over a table: colour gradients, wood-grain stripes, a soft checker and fine static texture."""
    h, w = wl.height + 2 * _PAN_MARGIN, wl.width + 2 * _PAN_MARGIN
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
    v = (yy / (h - 1))[..., None]
    wall_top = np.array([200, 210, 225] if cam == 0 else [180, 190, 170], np.float32)
    wall_bottom = np.array([150, 160, 180] if cam == 0 else [140, 150, 130], np.float32)
    wall = wall_top * (1 - v) + wall_bottom * v
    grain = 9 * np.sin(xx * 0.21 + 3 * np.sin(yy * 0.037)) + 6 * np.sign(np.sin(xx * 0.098) * np.sin(yy * 0.098))
    table = np.array([140, 105, 70], np.float32) * (0.8 + 0.3 * v) + grain[..., None]
    edge = np.clip((yy - 0.45 * h) / 3 + 0.5, 0, 1)[..., None]  # anti-aliased table edge
    img = wall * (1 - edge) + table * edge
    rng = np.random.default_rng(1234 + cam)
    texture = _box_blur(rng.normal(0, 1, (h, w)).astype(np.float32)) * 9
    out: FloatArray = (img + texture[..., None]).astype(np.float32)
    return out


def _blend(img: FloatArray, y0: int, x0: int, alpha: FloatArray, color: FloatArray) -> None:
    hh, ww = alpha.shape[:2]
    win = img[y0 : y0 + hh, x0 : x0 + ww]
    win *= 1 - alpha
    win += color * alpha


def _disc(img: FloatArray, cx: float, cy: float, r: float, color: FloatArray, opacity: float = 1.0) -> None:
    """An anti-aliased disc, shaded like a sphere lit from the top left (or a soft shadow: dark, translucent)."""
    h, w = img.shape[:2]
    x0, x1 = max(int(cx - r - 1), 0), min(int(cx + r + 2), w)
    y0, y1 = max(int(cy - r - 1), 0), min(int(cy + r + 2), h)
    if x0 >= x1 or y0 >= y1:
        return
    yy, xx = np.ogrid[y0:y1, x0:x1]
    d = np.sqrt((xx - cx) ** 2 + (yy - cy) ** 2, dtype=np.float32)
    alpha = (np.clip(r + 0.5 - d, 0, 1) * opacity)[..., None]
    hx, hy = cx - 0.35 * r, cy - 0.35 * r
    highlight = np.sqrt((xx - hx) ** 2 + (yy - hy) ** 2, dtype=np.float32) / (1.6 * r)
    shade = np.clip(1.15 - 0.55 * highlight, 0.45, 1.15)[..., None]
    _blend(img, y0, x0, alpha.astype(np.float32), (color * shade).astype(np.float32))


def _box(img: FloatArray, x0f: float, y0f: float, x1f: float, y1f: float, color: FloatArray) -> None:
    """An anti-aliased axis-aligned rectangle with a vertical shading ramp."""
    h, w = img.shape[:2]
    x0, x1 = max(int(x0f) - 1, 0), min(int(x1f) + 2, w)
    y0, y1 = max(int(y0f) - 1, 0), min(int(y1f) + 2, h)
    if x0 >= x1 or y0 >= y1:
        return
    yy, xx = np.ogrid[y0:y1, x0:x1]
    ax = np.clip(np.minimum(xx - x0f, x1f - xx) + 0.5, 0, 1)
    ay = np.clip(np.minimum(yy - y0f, y1f - yy) + 0.5, 0, 1)
    alpha = (ax * ay).astype(np.float32)[..., None]
    ramp = (0.85 + 0.3 * (yy - y0f) / max(y1f - y0f, 1)).astype(np.float32)[..., None]
    _blend(img, y0, x0, alpha, color * ramp)


def _render_episode(episode: int, wl: Workload, backgrounds: list[FloatArray]) -> dict[str, ImageArray]:
    rng = np.random.default_rng(10_000 + episode)
    colors = [rng.uniform(40, 230, 3).astype(np.float32) for _ in range(3)]
    gripper_color = np.array([70, 70, 78], np.float32)
    shadow = np.zeros(3, np.float32)
    phases = rng.uniform(0, 2 * math.pi, 4)
    light = float(rng.uniform(0.9, 1.1))
    h, w = wl.height, wl.width
    out: dict[str, ImageArray] = {cam: np.empty((wl.frames, h, w, 3), np.uint8) for cam in wl.cameras}
    for t in range(wl.frames):
        s = t / max(wl.frames - 1, 1)  # progress through the episode
        # world state in front-camera pixels: two objects on the table, a gripper reaching for the first
        ax = w * (0.35 + 0.15 * math.sin(2 * math.pi * s + phases[0]))
        ay = h * (0.68 + 0.06 * math.sin(4 * math.pi * s + phases[1]))
        bx = w * (0.7 + 0.1 * math.sin(3 * math.pi * s + phases[2]))
        by = h * (0.8 + 0.04 * math.cos(2 * math.pi * s + phases[3]))
        gx = w * 0.5 + (ax - w * 0.5) * min(1.0, 1.5 * s) + 8 * math.sin(12 * math.pi * s)
        gy = h * 0.15 + (ay - 30 - h * 0.15) * min(1.0, 1.3 * s)
        for cam_index, cam in enumerate(wl.cameras):
            if cam_index == 0:  # static third-person view
                img = backgrounds[cam_index][_PAN_MARGIN : _PAN_MARGIN + h, _PAN_MARGIN : _PAN_MARGIN + w].copy()
                _disc(img, ax + 6, ay + 8, 17, shadow, 0.3)
                _disc(img, ax, ay, 16, colors[0])
                _box(img, bx - 14, by - 14, bx + 14, by + 14, colors[1])
                _box(img, gx - 6, 0, gx + 6, gy, gripper_color)  # arm
                _box(img, gx - 16, gy, gx - 10, gy + 22, colors[2])  # fingers
                _box(img, gx + 10, gy, gx + 16, gy + 22, colors[2])
            else:  # wrist view: pans with the gripper, sees the objects up close
                ox = int(np.clip(_PAN_MARGIN + 0.25 * (gx - w / 2), 0, 2 * _PAN_MARGIN))
                oy = int(np.clip(_PAN_MARGIN + 0.25 * (gy - h / 2), 0, 2 * _PAN_MARGIN))
                img = backgrounds[cam_index][oy : oy + h, ox : ox + w].copy()
                zoom = 1.8  # objects seen from the gripper, which sits above the frame centre
                pax, pay = w / 2 + zoom * (ax - gx), h * 0.35 + zoom * (ay - gy)
                pbx, pby = w / 2 + zoom * (bx - gx), h * 0.35 + zoom * (by - gy)
                _disc(img, pax, pay, 16 * zoom, colors[0])
                _box(img, pbx - 14 * zoom, pby - 14 * zoom, pbx + 14 * zoom, pby + 14 * zoom, colors[1])
                _box(img, w * 0.18, h * 0.78, w * 0.3, h, colors[2])  # the fingers, fixed in this view
                _box(img, w * 0.7, h * 0.78, w * 0.82, h, colors[2])
            np.clip(img * light, 0, 255, out=img)
            out[cam][t] = img.astype(np.uint8)
    return out


def make_data(wl: Workload) -> list[EpisodeData]:
    backgrounds = [_background(i, wl) for i in range(len(wl.cameras))]
    data = []
    t = np.arange(wl.frames, dtype=np.float32)[:, None]
    for e in range(wl.episodes):
        states = np.sin(0.05 * t + np.arange(wl.state_dim, dtype=np.float32) + 0.3 * e).astype(np.float32)
        actions = np.cos(0.07 * t + np.arange(wl.action_dim, dtype=np.float32) - 0.2 * e).astype(np.float32)
        data.append(EpisodeData(_render_episode(e, wl, backgrounds), states, actions))
    return data


def bench_schema(wl: Workload) -> Any:
    """The DatasetSchema of workload W (shared by the writer and MCAP benchmarks)."""
    from openral_data.types import CameraShape, DatasetSchema

    return DatasetSchema(
        fps=wl.fps,
        state_names=tuple(f"s{i}" for i in range(wl.state_dim)),
        action_names=tuple(f"a{i}" for i in range(wl.action_dim)),
        cameras={cam: CameraShape(wl.height, wl.width) for cam in wl.cameras},
        robot_type="bench",
    )


def feed_bridge(sinks: list[Any], data: list[EpisodeData], wl: Workload) -> None:
    """Record workload W through DatasetBridge into `sinks` (what `record` does), closing them at the end."""
    from openral_data.runtime.bridge import DatasetBridge
    from openral_data.types import Observation

    bridge = DatasetBridge(bench_schema(wl), sinks)
    last = wl.frames - 1
    try:
        for seed, ep in enumerate(data):
            bridge.begin_episode(seed, {"seed": seed})
            for t in range(wl.frames):
                obs = Observation(
                    images={cam: ep.images[cam][t] for cam in wl.cameras}, state=ep.states[t], task=wl.task,
                    time=t / wl.fps,
                )  # fmt: skip
                bridge.add_step(obs, ep.actions[t], reward=0.0, done=t == last, success=False)
            bridge.end_episode(success=True)
    finally:
        bridge.close()
