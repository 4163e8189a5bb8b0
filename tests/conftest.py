"""Shared fixtures: an isolated project home (robots/, rskills/, scenes/, datasets/) and offline HF caches.
Helpers live in tests/support/."""

from __future__ import annotations

import os
import signal
from collections.abc import Iterator
from pathlib import Path

import pytest

from tests.support.home import isolated_home

# The pre-publish check's lerobot frame load (formats/lerobot_v3/loadable.py) imports lerobot and torch in every
# command that publishes a dataset: seconds of CPU in each of the suite's hundreds of short CLI runs. The suite
# keeps the structural check everywhere; the tests of the frame load turn it on (`publish_load`), and many tests
# load outputs with lerobot themselves.
os.environ.setdefault("OPENRAL_PUBLISH_LOAD", "0")
# The CLI wraps its summaries and fits its tables to `$COLUMNS` when its output is piped (cli/terminal.py), and
# pytest-xdist's workers are started with COLUMNS=80 LINES=24 (execnet), which every CLI subprocess would inherit:
# a test passing alone then failed under `-n 2`. The suite runs the CLI as a pipe with no width, as a log or a
# script sees it; the tests of widths set `COLUMNS` themselves (monkeypatch).
for _name in ("COLUMNS", "LINES"):
    os.environ.pop(_name, None)


def pytest_configure(config: pytest.Config) -> None:
    """Tests send Ctrl-C (SIGINT) to the processes they start and expect them to stop as at a terminal. A harness
    that starts pytest in the background of a non-interactive shell (`.ci/run &`) leaves SIGINT ignored, and an
    ignored signal stays ignored in every child (Python then installs no KeyboardInterrupt handler): restore the
    default here, in the controller and in each xdist worker, so children start with it."""
    if signal.getsignal(signal.SIGINT) == signal.SIG_IGN:
        signal.signal(signal.SIGINT, signal.default_int_handler)


@pytest.fixture(autouse=True, scope="session")
def _offline_hf(tmp_path_factory: pytest.TempPathFactory) -> Iterator[None]:
    """lerobot's loader must never reach for the Hub, and its Arrow cache must not leak into ~/.cache."""
    hf = tmp_path_factory.mktemp("hf_home")
    old = {k: os.environ.get(k) for k in ("HF_HOME", "HF_HUB_OFFLINE", "HF_DATASETS_OFFLINE")}
    os.environ.update({"HF_HOME": str(hf), "HF_HUB_OFFLINE": "1", "HF_DATASETS_OFFLINE": "1"})
    yield
    for k, v in old.items():
        if v is None:
            os.environ.pop(k, None)
        else:
            os.environ[k] = v


@pytest.fixture(scope="session")
def core_venv(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The wheel and its core dependencies in a fresh venv (tests/support/wheel.py), made once per session: the
    modules using it are in xdist group "wheel", so one worker makes it."""
    from tests.support.wheel import build_core_venv

    return build_core_venv(tmp_path_factory.mktemp("install"))


@pytest.fixture
def project(tmp_path: Path) -> Iterator[Path]:
    """A copy of the repo's manifests in tmp, used as OPENRAL_DATA_HOME, so tests can add broken files
    (module-scoped fixtures enter `isolated_home` themselves)."""
    with isolated_home(tmp_path) as home:
        yield home


@pytest.fixture
def publish_load(monkeypatch: pytest.MonkeyPatch) -> None:
    """The pre-publish check loads frames with lerobot, as it does for users (OPENRAL_PUBLISH_LOAD=1)."""
    monkeypatch.setenv("OPENRAL_PUBLISH_LOAD", "1")
