#!/usr/bin/env bash
# Install what the server needs (system GL libraries, a .venv with simx) and start it.
# Arguments go to simx-server: scripts/serve.sh [scene.xml] [--port N] [--speed S] ...
# The first run installs (a minute or two, saying so); later runs start in a few seconds.
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/_env.sh"
echo "simx: checking the system packages (GL libraries for offscreen rendering) ..."
bash "$ROOT/scripts/system-deps.sh"
ensure_venv -e "$ROOT"
export MUJOCO_GL="${MUJOCO_GL:-egl}"
echo "simx: starting simx-server $* (it prints a ready line when clients can connect) ..."
exec "$VENV/bin/simx-server" "$@"
