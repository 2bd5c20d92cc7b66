#!/usr/bin/env bash
# Install what the server needs (system GL libraries, a .venv with simx) and start it.
# Arguments go to simx-server: scripts/serve.sh [scene.xml] [--port N] [--speed S] ...
# --with-viewer (not passed on) also installs what simx-viewer's window needs: the X libraries
# GLFW opens (scripts/system-deps.sh --with-x); run .venv/bin/simx-viewer beside the server.
# The first run installs (a minute or two, saying so); later runs start in a few seconds.
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/_env.sh"
deps=()
args=()
for arg in "$@"; do
  if [ "$arg" = --with-viewer ]; then deps=(--with-x); else args+=("$arg"); fi
done
echo "simx: checking the system packages (GL libraries for offscreen rendering${deps[*]:+, X libraries for simx-viewer}) ..."
bash "$ROOT/scripts/system-deps.sh" ${deps[@]+"${deps[@]}"}
ensure_venv -e "$ROOT"
export MUJOCO_GL="${MUJOCO_GL:-egl}"
# The banner avoids the word the server's own line starts with ("simx-server ready: ..."), so
# that a script waiting for that line (grep) does not take this one for it.
echo "simx: starting simx-server ${args[*]-} (clients can connect once simx-server says so below) ..."
[ ${#deps[@]} -gt 0 ] && echo "simx: to watch the scene, run $VENV/bin/simx-viewer in another terminal (X display needed)."
exec "$VENV/bin/simx-server" ${args[@]+"${args[@]}"}
