#!/usr/bin/env bash
# Install what the benchmarks need (system GL, Xvfb, xdotool, a .venv with simx[test,bench])
# and run them. Arguments go to benchmarks.run: scripts/bench.sh [--quick] [--only calls,images]
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/_env.sh"
bash "$ROOT/scripts/system-deps.sh" --with-x
ensure_venv -e "$ROOT[test,bench]"
export MUJOCO_GL="${MUJOCO_GL:-egl}"
cd "$ROOT"
exec "$VENV/bin/python" -m benchmarks.run "$@"
