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
