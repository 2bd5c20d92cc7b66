#!/usr/bin/env bash
# Install everything the tests need (GL libraries, Xvfb, xdotool, a .venv with simx[test])
# and run the whole test suite. Extra arguments go to pytest.
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/_env.sh"
bash "$ROOT/scripts/system-deps.sh" --with-x
ensure_venv -e "$ROOT[test]"
export MUJOCO_GL="${MUJOCO_GL:-egl}"
cd "$ROOT"
echo "simx: running the tests: pytest -ra${*:+ $*} (the whole suite takes about 3 minutes on 2 cores) ..."
exec "$VENV/bin/python" -m pytest -ra "$@"
