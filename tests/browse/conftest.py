"""The dataset the browse tests look at: lerobot 0.6.1's own output (three episodes of 6, 9, 4 frames; camera
frames a flat grey of 10 * t, so each frame is told from its neighbours; episode 1 failed), and the real Chromium
(Debian's) the page tests drive through Playwright."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from tests.support.lerobot_written import write_lerobot_dataset

CHROMIUM = "/usr/bin/chromium"


@pytest.fixture(scope="session")
def browse_dataset(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("browse") / "ds"
    write_lerobot_dataset(root, True)
    return root


@pytest.fixture(scope="module")
def chromium() -> Iterator[Any]:
    from playwright.sync_api import sync_playwright

    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, args=["--autoplay-policy=no-user-gesture-required"])
        yield browser
        browser.close()


@pytest.fixture
def page(chromium: Any) -> Iterator[Any]:
    context = chromium.new_context()
    yield context.new_page()
    context.close()
