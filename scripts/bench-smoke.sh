#!/usr/bin/env bash
# Every suite of benchmarks.run, the opt-in ones too, in its tiniest form (--smoke: a few
# iterations, no figure asserted or meant): that each still runs. Exits non-zero when a suite
# fails, or skips a figure for another reason than something optional this machine lacks (each is
# named; the tutorial row needs ../shared, Xvfb and port 19999, and says so when it cannot run).
# .ci/run runs it after the tests, in the same environment (scripts/test.sh's, nothing more is
# installed). Arguments go to benchmarks.run (e.g. --only images,sync).
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/_env.sh"
ensure_test_venv
export MUJOCO_GL="${MUJOCO_GL:-egl}"
# One BLAS and one OpenMP thread per process, as for the tests (scripts/test.sh).
export OPENBLAS_NUM_THREADS="${OPENBLAS_NUM_THREADS:-1}" OMP_NUM_THREADS="${OMP_NUM_THREADS:-1}"
cd "$ROOT"
# Bytecode caches written (gitignored __pycache__), as for the tests (scripts/test.sh): the run starts
# about 60 Python processes, each of which would compile the modules it imports again.
unset PYTHONDONTWRITEBYTECODE
start=$SECONDS
status=0
"$VENV/bin/python" -m benchmarks.run --smoke "$@" || status=$?
echo "simx: the benchmark smoke run took $((SECONDS - start)) s (exit status $status)."
exit "$status"
