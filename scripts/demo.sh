#!/usr/bin/env bash
# Install, record a small real-physics demo dataset (tabletop_push, Franka Panda, scripted expert, 3 episodes)
# and print its summary. Extra arguments are passed to `record` (later options win, e.g. --robot ur5e).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
export MUJOCO_GL="${MUJOCO_GL:-egl}"
out="datasets/demo-$(date +%Y%m%d-%H%M%S)"
.venv/bin/openral-data record --scene tabletop_push --rskill scripted-push --n-episodes 3 --out "$out" "$@"
.venv/bin/openral-data info "$out"
