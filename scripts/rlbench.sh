#!/usr/bin/env bash
# RLBench, unchanged, on simx's pyrep: install simx with its rlbench extra (the pyrep extra and
# RLBench's own requirements but its PyRep) and RLBench itself without its dependencies (its
# PyRep is CoppeliaSim's: simx's pyrep takes its place), then run examples/rlbench_demo.py:
#   scripts/rlbench.sh [TASK] [--scene task_design.ttt]
# SIMX_RLBENCH: where RLBench comes from (default git+https://github.com/stepjam/RLBench.git;
# a clone made with git-lfs brings its main scene, rlbench/task_design.ttt).
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/_env.sh"
echo "simx: checking the system packages (GL libraries for offscreen rendering) ..."
bash "$ROOT/scripts/system-deps.sh"
ensure_venv -e "$ROOT[rlbench]"
if ! "$VENV/bin/python" -c 'import rlbench' 2>/dev/null; then
  echo "simx: installing RLBench (${SIMX_RLBENCH:-git+https://github.com/stepjam/RLBench.git}) without its PyRep ..."
  "$VENV/bin/python" -m pip install --quiet --disable-pip-version-check --no-deps \
      "${SIMX_RLBENCH:-git+https://github.com/stepjam/RLBench.git}"
fi
export MUJOCO_GL="${MUJOCO_GL:-egl}"
exec "$VENV/bin/python" "$ROOT/examples/rlbench_demo.py" "$@"
