#!/usr/bin/env bash
# Install the core (MuJoCo, no torch: scripts/setup.sh --core), record a small real-physics demo dataset
# (tabletop_push, Franka Panda, scripted expert, 3 episodes), print its summary and three commands to try next.
# Extra arguments are passed to `record` (later options win, e.g. --robot ur5e).
set -euo pipefail
cd "$(dirname "$0")/.."
echo "demo: 1/3 installing the core (scripts/setup.sh --core; minutes the first time, seconds after)" >&2
bash scripts/setup.sh --core
export MUJOCO_GL="${MUJOCO_GL:-egl}"
out="datasets/demo-$(date +%Y%m%d-%H%M%S)"
echo "demo: 2/3 recording 3 tabletop_push episodes into $out (about 1-2 min)" >&2
t0=$SECONDS
.venv/bin/openral-data record --scene tabletop_push --rskill scripted-push --n-episodes 3 --out "$out" "$@"
echo "demo:   recorded in $((SECONDS - t0)) s" >&2
echo "demo: 3/3 the dataset's summary (openral-data info $out)" >&2
.venv/bin/openral-data info "$out"
cat <<EOF

next: \`source .venv/bin/activate\` (once per shell), then for example
  openral-data quality $out   # each episode scored: idle time, jerk, camera faults
  openral-data replay $out    # its actions replayed in MuJoCo, checked against the recording
  openral-data list scenes    # what else records here (README.md and docs/ for the rest)
EOF
