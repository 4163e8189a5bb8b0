"""What the browse page tests read off a page in Chromium."""

from __future__ import annotations

from typing import Any


def plots(page: Any, url: str) -> list[list[Any]]:
    """Open episode page `url` and return its plots: [feature, [[series name, points drawn], ...]] each."""
    page.goto(url)
    page.wait_for_selector("body[data-ready='1']")
    plotted: list[list[Any]] = page.eval_on_selector_all(
        "svg.plot",
        "svgs => svgs.map(s => [s.dataset.feature, [...s.querySelectorAll('polyline')].map("
        "p => [p.dataset.series, p.getAttribute('points').split(' ').length])])",
    )
    return plotted


# draws the leading video's frame at frame k (seeking there first unless k is None) and returns its RGBA pixels
GRAB = """async ([k, fps]) => {
  const v = document.querySelector('video');
  if (v.readyState < 2) await new Promise(r => v.addEventListener('loadeddata', r, {once: true}));
  if (k !== null) {
    // 'seeked' may come before the new frame is presented (seen on a loaded machine: the canvas got the frame
    // before it), so wait for the frame callback too (bounded, should a browser never call it for a paused video)
    const shown = new Promise(r => v.requestVideoFrameCallback(() => r()));
    const seeked = new Promise(r => v.addEventListener('seeked', r, {once: true}));
    v.currentTime = Number(v.dataset.from) + k / fps;
    await seeked;
    await Promise.race([shown, new Promise(r => setTimeout(r, 5000))]);
  }
  const c = document.createElement('canvas');
  c.width = v.videoWidth; c.height = v.videoHeight;
  const g = c.getContext('2d');
  g.drawImage(v, 0, 0);
  return Array.from(g.getImageData(0, 0, c.width, c.height).data);
}"""


def grey(page: Any, k: int | None, fps: int = 10) -> float:
    """The mean grey level of the video frame shown (after seeking to frame k when given): the browse dataset's
    frame t is a flat grey of 10 * t."""
    pixels = page.evaluate(GRAB, [k, fps])
    rgb = [p for i, p in enumerate(pixels) if i % 4 != 3]
    return sum(rgb) / len(rgb)
