"""The episode page in a real Chromium (Debian's, through Playwright) against the real server, on the browse
dataset with its quality findings computed (`openral-data quality`: the camera's first frame is black, grey
10 * t): a click on a plot seeks the video to that frame, playback stops on the episode's last
frame (not in the next episode of the shared mp4), previous/next step through the episodes (under the table's
filter), hovering reads the values, a dimension hidden or scaled on its own changes what the axis spans, the
quality spans are on the timeline; and the screenshots in docs/ at 1280x800 and 390x844 (no sideways scroll)."""

from __future__ import annotations

import os
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from openral_data.browse import Browser, open_catalogs
from openral_data.metrics.quality import quality_of
from openral_data.metrics.sources import open_dataset
from tests.browse.pages import grey

READY = "body[data-ready='1']"


@pytest.fixture(scope="module")
def server(browse_dataset: Path, tmp_path_factory: pytest.TempPathFactory) -> Iterator[Browser]:
    with pytest.MonkeyPatch.context() as mp:  # the quality cache of a lerobot-written dataset: the user's cache
        mp.setenv("XDG_CACHE_HOME", str(tmp_path_factory.mktemp("cache")))
        quality_of(open_dataset(browse_dataset))
        browser = Browser(open_catalogs([str(browse_dataset)]))
    browser.start()
    yield browser
    browser.close()


def _open(page: Any, server: Browser, path: str) -> None:
    page.goto(server.url + path)
    page.wait_for_selector(READY)
    page.wait_for_function("() => document.querySelector('video').readyState >= 2")


def _click_frame(page: Any, feature: str, k: int, frames: int, action: str = "click") -> None:
    """Click (or hover) the plot of `feature` at frame `k` (the plot's inner area starts 56 px in, ends 12 px
    before its right edge: plot.js PAD)."""
    box = page.locator(f"svg.plot[data-feature='{feature}']").bounding_box()
    x = box["x"] + 56 + (box["width"] - 68) * k / (frames - 1)
    getattr(page.mouse, action)(x, box["y"] + box["height"] / 2)


def test_a_click_on_a_plot_seeks_the_video_to_that_frame(server: Browser, page: Any) -> None:
    _open(page, server, "d/0/episode/1")
    _click_frame(page, "action", 6, 9)
    page.wait_for_function("() => document.getElementById('frame').value === '6'")
    page.wait_for_function("() => !document.querySelector('video').seeking")
    assert page.text_content("#counter") == "frame 6 / 8 · 0.60 s"
    assert abs(grey(page, None) - 60) < 3  # frame 6 of the episode is grey 60
    cursor = float(page.get_attribute("svg.plot[data-feature='observation.state'] line.cursor", "x1"))
    box = page.locator("svg.plot[data-feature='observation.state']").bounding_box()
    assert cursor == pytest.approx(56 + (box["width"] - 68) * 6 / 8, abs=0.2)  # every plot's cursor moved there


def test_playback_stops_on_the_episodes_last_frame(server: Browser, page: Any) -> None:
    """Episode 1 (9 frames) is followed in the mp4 by episode 2, whose first frame is black: playing to the end
    must leave frame 8 (grey 80) on screen, the time at the episode's last frame."""
    _open(page, server, "d/0/episode/1")
    page.eval_on_selector("#frame", "s => { s.value = '5'; s.dispatchEvent(new Event('input')); }")
    page.wait_for_function("() => !document.querySelector('video').seeking")
    page.click("#play")
    page.wait_for_function("() => document.querySelector('video').paused && !document.querySelector('video').seeking")
    start = float(page.get_attribute("video", "data-from"))
    assert page.evaluate("document.querySelector('video').currentTime") == pytest.approx(start + 0.8, abs=1e-3)
    assert abs(grey(page, None) - 80) < 3
    assert page.text_content("#counter").startswith("frame 8 / 8")


def test_previous_and_next_step_through_the_episodes(server: Browser, page: Any) -> None:
    _open(page, server, "d/0/episode/1")
    assert page.get_attribute("#previous", "href") == "/d/0/episode/0"
    page.click("#next")
    page.wait_for_url("**/d/0/episode/2")
    page.wait_for_selector(READY)
    assert page.text_content("#title") == "episode 2"
    assert page.get_attribute("#next", "href") is None  # the last episode
    page.goto(server.url + "d/0/episode/2?where=length+%3C%3E+9")  # opened from a table filtered on length <> 9
    page.wait_for_selector(READY)
    assert page.get_attribute("#previous", "href") == "/d/0/episode/0?where=length+%3C%3E+9"  # episode 1 skipped


def test_hovering_a_plot_reads_the_values_at_that_frame(server: Browser, page: Any) -> None:
    _open(page, server, "d/0/episode/1")
    _click_frame(page, "action", 5, 9, "move")
    readout = page.locator("section[data-feature='action'] .readout")
    readout.wait_for(state="visible")
    values = readout.locator("[data-series]").all_text_contents()
    assert readout.locator("b").text_content() == "frame 5"
    assert values == ["vx 0.5", "vy -0.5"]  # action = (0.1 t, -0.1 t)


def test_hiding_a_dimension_or_scaling_each_rescales_the_plot(server: Browser, page: Any) -> None:
    """state (x, y, z) = (t, 1, 0.5): on a shared axis x spans 0..8 and y, z lie close; with x hidden the axis
    spans only 0.5..1 and their lines move apart. Action (vx, vy) = (0.1 t, -0.1 t): each on its own range, vx
    climbs the whole plot instead of its upper half."""
    _open(page, server, "d/0/episode/1")

    def height(feature: str, series: str) -> float:
        points = page.get_attribute(f"svg.plot[data-feature='{feature}'] polyline[data-series='{series}']", "points")
        ys = [float(p.split(",")[1]) for p in points.split()]
        return max(ys) - min(ys)

    def gap() -> float:
        ys = [
            float(
                page.get_attribute(f"svg.plot[data-feature='observation.state'] polyline[data-series='{s}']", "points")
                .split()[0]
                .split(",")[1]
            )
            for s in "yz"
        ]
        return abs(ys[0] - ys[1])

    before = gap()
    page.uncheck("section[data-feature='observation.state'] input[data-series='x']")
    assert gap() > 5 * before
    assert (
        page.get_attribute("svg.plot[data-feature='observation.state'] polyline[data-series='x']", "visibility")
        == "hidden"
    )
    shared = height("action", "vx")
    page.select_option("section[data-feature='action'] select.scale", "each")
    assert height("action", "vx") == pytest.approx(2 * shared, rel=0.05)
    # a plot starts on "each" when one dimension would flatten another: a 0..1 gripper beside 2 cm of travel
    starts = page.evaluate(
        """() => [[1, 0.02], [1, 0.5]].map(([g, x]) => new Plot('f', [{name: 'gripper', values: [0, g, 0]},
             {name: 'x', values: [0, x / 2, x]}], 3, [], () => {}).scale)"""
    )
    assert starts == ["each", "shared"]


def test_the_quality_spans_are_on_the_timeline(server: Browser, page: Any) -> None:
    _open(page, server, "d/0/episode/1")
    black = page.locator("#timeline rect.span[data-check='camera_black']")
    assert black.count() == 1  # frames 0-2: the first frame is black (grey 0), the camera sampled every 5th
    assert float(black.get_attribute("x")) == 0 and float(black.get_attribute("width")) == pytest.approx(1000 * 2.5 / 8)
    assert "camera_black" in page.text_content("#flags")
    assert "frames 0–2" in page.text_content("button.finding.check-camera_black")
    page.eval_on_selector("#frame", "s => { s.value = '6'; s.dispatchEvent(new Event('input')); }")
    page.click("button.finding.check-camera_black")  # a click goes to the finding's first frame
    page.wait_for_function("() => document.getElementById('frame').value === '0'")


def test_screenshots_at_desktop_and_phone_size(server: Browser, chromium: Any, tmp_path: Path) -> None:
    """The pictures in docs/ (browse-table.png, browse-episode.png, browse-episode-phone.png) come from here:
    run once with OPENRAL_SCREENSHOTS=docs to refresh them. At 390 px nothing scrolls sideways."""
    folder = Path(os.environ.get("OPENRAL_SCREENSHOTS", tmp_path))
    for (width, height), name in (((1280, 800), "browse-episode.png"), ((390, 844), "browse-episode-phone.png")):
        context = chromium.new_context(viewport={"width": width, "height": height})
        page = context.new_page()
        try:
            if width == 1280:
                page.goto(server.url + "d/0/")
                page.wait_for_function("() => document.querySelectorAll('#episodes tbody tr').length === 3")
                page.check("#episodes tbody tr[data-episode='1'] input[type=checkbox]")
                page.wait_for_selector("#command-delete")
                page.screenshot(path=str(folder / "browse-table.png"))
            _open(page, server, "d/0/episode/1")
            _click_frame(page, "observation.state", 6, 9)
            page.wait_for_function("() => !document.querySelector('video').seeking")
            _click_frame(page, "action", 4, 9, "move")  # a readout in the picture
            assert page.evaluate("document.documentElement.scrollWidth") <= width
            page.screenshot(path=str(folder / name), full_page=width < 1280)
        finally:
            context.close()
    assert (folder / "browse-episode.png").stat().st_size > 1000
