#!/usr/bin/env bash
# Install, lint, type-check and run the whole test-suite (including the slow end-to-end tests).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
export MUJOCO_GL="${MUJOCO_GL:-egl}"
.venv/bin/ruff check openral_data tests benchmarks
.venv/bin/ruff format --check openral_data tests benchmarks
.venv/bin/mypy
.venv/bin/lint-imports
.venv/bin/pytest "$@"
