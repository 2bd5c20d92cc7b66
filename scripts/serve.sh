#!/usr/bin/env bash
# Install what the server needs (system GL libraries, a .venv with simx) and start it.
# Arguments go to simx-server: scripts/serve.sh [scene.xml] [--port N] [--speed S] ...
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/_env.sh"
bash "$ROOT/scripts/system-deps.sh"
ensure_venv "$ROOT"
export MUJOCO_GL="${MUJOCO_GL:-egl}"
exec "$VENV/bin/simx-server" "$@"
