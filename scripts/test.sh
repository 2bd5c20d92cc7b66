#!/usr/bin/env bash
# Install everything the tests need (GL libraries, Xvfb, xdotool, a .venv with simx[test])
# and run the whole test suite. Extra arguments go to pytest.
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/_env.sh"
bash "$ROOT/scripts/system-deps.sh" --with-x
# SIMX_TEST_EXTRAS: the extras installed (default "test"; .ci/run adds train and ray, whose tests
# skip without them; with either, PyTorch's CPU build, as scripts/install-train.sh installs it);
# SIMX_PIP_ARGS: more for the same pip install.
ensure_test_venv
export MUJOCO_GL="${MUJOCO_GL:-egl}"
cd "$ROOT"
# The suite writes bytecode caches (gitignored __pycache__): it starts about 165 simx-server
# processes and as many client programs, and with PYTHONDONTWRITEBYTECODE set (this project's
# machines set it) each would compile ~80 modules again (0.1-0.15 s of CPU each time) and each
# pytest worker would rewrite every test module's asserts again (2.5 s): 126 s instead of 150 s.
unset PYTHONDONTWRITEBYTECODE
# One BLAS and one OpenMP thread per test process (4 workers and their client programs already
# share 2 cores): OpenBLAS would start one per core in each, 0.08 s of CPU at every numpy import,
# and PyTorch's spinning OpenMP threads cost the DDPG smoke test 4 s of CPU.
export OPENBLAS_NUM_THREADS="${OPENBLAS_NUM_THREADS:-1}" OMP_NUM_THREADS="${OMP_NUM_THREADS:-1}"
# The tests mostly wait on real servers (subprocesses), so 4 pytest-xdist workers keep 2 cores busy;
# --dist loadfile keeps a module's tests, and the server its fixture starts, on one worker.
# SIMX_TEST_WORKERS=0 runs them in this process, one after the other.
workers="${SIMX_TEST_WORKERS:-4}"
dist=()
# --no-loadscope-reorder: files are queued longest first (tests/conftest.py, SLOW_FILES), not by test count.
[ "$workers" != 0 ] && dist=(-n "$workers" --dist loadfile --no-loadscope-reorder)
echo "simx: running the tests: pytest -ra ${dist[*]}${*:+ $*} (the whole suite takes about 7 minutes on 2 quiet cores: about 545 s of CPU) ..."
start=$SECONDS
status=0
if [ $# -eq 0 ] && [ "$workers" != 0 ]; then
  # The whole suite: the two-node Ray cluster test (marker "ray") runs alone after the others.
  # Beside three busy workers on 2 cores its env runners' Zenoh sessions to their servers lost
  # their lease or a step took over 20 s (3 of the last 8 clean runs); alone it takes about 30 s,
  # about what it added to the parallel run. Each run writes a JUnit report; the last lines are
  # the total of both (scripts/suite_total.py), as neither run's own count is the suite's.
  reports=$(mktemp -d)
  trap 'rm -rf "$reports"' EXIT
  "$VENV/bin/python" -m pytest -ra "${dist[@]}" -m "not ray" --junitxml="$reports/main.xml" || status=$?
  ray_status=0
  "$VENV/bin/python" -m pytest -ra -m ray --junitxml="$reports/ray.xml" || ray_status=$?
  [ "$ray_status" = 5 ] && ray_status=0  # no test has the marker: nothing to run
  [ "$status" = 0 ] && status=$ray_status
  echo "simx: the tests took $((SECONDS - start)) s (exit status $status)."
  "$VENV/bin/python" "$ROOT/scripts/suite_total.py" "$reports/main.xml" "$reports/ray.xml"
else
  "$VENV/bin/python" -m pytest -ra ${dist[@]+"${dist[@]}"} "$@" || status=$?
  echo "simx: the tests took $((SECONDS - start)) s (exit status $status)."
fi
exit "$status"
