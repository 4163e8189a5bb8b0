#!/usr/bin/env bash
# Install, record a small real-physics demo dataset (tabletop_push, Franka Panda, scripted expert, 3 episodes)
# and print its summary. Extra arguments are passed to `record` (later options win, e.g. --robot ur5e).
set -euo pipefail
cd "$(dirname "$0")/.."
echo "demo: 1/3 installing (scripts/setup.sh; minutes the first time, seconds after)" >&2
bash scripts/setup.sh
export MUJOCO_GL="${MUJOCO_GL:-egl}"
out="datasets/demo-$(date +%Y%m%d-%H%M%S)"
echo "demo: 2/3 recording 3 tabletop_push episodes into $out (about 1-2 min)" >&2
t0=$SECONDS
.venv/bin/openral-data record --scene tabletop_push --rskill scripted-push --n-episodes 3 --out "$out" "$@"
echo "demo:   recorded in $((SECONDS - t0)) s" >&2
echo "demo: 3/3 the dataset's summary (openral-data info $out)" >&2
.venv/bin/openral-data info "$out"
