#!/usr/bin/env bash
# Install, record a demo dataset on the default scene, and print its summary.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
export MUJOCO_GL="${MUJOCO_GL:-egl}"
out="datasets/demo-$(date +%Y%m%d-%H%M%S)"
.venv/bin/openral-data record --out "$out" "$@"
.venv/bin/openral-data info "$out"
