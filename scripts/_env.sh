# Sourced by serve.sh, test.sh and bench.sh: a virtual environment in .venv (or $SIMX_VENV) with
# the project installed (editable, so the repository's code is what runs).
# Usage: ensure_venv [pip install arguments...]
#
# It says what it does: creating the environment, installing the Python packages (the first run
# downloads MuJoCo, Zenoh, OpenCV, ...: 20-30 s here, minutes on a slow connection), or that nothing
# needs installing. A stamp per set of arguments in the environment ($VENV/.simx-installed-*)
# holds a hash of pyproject.toml, this file, the arguments and the Python version: later runs
# install again only when one of those changed (the code itself is installed editable, so its
# changes need no reinstall).
#
# An argument `torch==VERSION+cpu` (scripts/install-train.sh's TORCH_CPU) asks for PyTorch's CPU
# build, which PyPI does not have (its Linux torch is the CUDA build: 15 NVIDIA wheels, about 5 GB
# more): it is installed first from pip's configured indexes (a mirror or wheel folder that has it,
# as this project's CI machines do), else from PyTorch's CPU index ($SIMX_TORCH_INDEX); the
# install that follows then finds it satisfied.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
VENV="${SIMX_VENV:-$ROOT/.venv}"
# The PyTorch release the training examples and the shipped policy (docs/training/) were made with.
TORCH_CPU="${SIMX_TORCH:-torch==2.13.0+cpu}"
TORCH_INDEX="${SIMX_TORCH_INDEX:-https://download.pytorch.org/whl/cpu}"

ensure_venv() {
    local python="${PYTHON:-python3}"
    if ! "$python" -c 'import sys; sys.exit(sys.version_info < (3, 10))'; then
        echo "simx needs Python 3.10 or newer; $python is $("$python" --version 2>&1)" >&2
        exit 1
    fi
    local which want stamp start
    which="$(printf '%s\n' "$@" | sha256sum | cut -c1-12)"
    want="$({ cat "$ROOT/pyproject.toml" "$ROOT/scripts/_env.sh"; printf '%s\n' "$@"; "$python" --version; } 2>&1 \
            | sha256sum | cut -d' ' -f1)"
    stamp="$VENV/.simx-installed-$which"
    if [ -x "$VENV/bin/python" ] && [ -f "$stamp" ] && [ "$(cat "$stamp")" = "$want" ]; then
        echo "simx: Python environment $VENV is up to date (pyproject.toml unchanged): nothing to install."
        return 0
    fi
    start=$SECONDS
    if [ ! -x "$VENV/bin/python" ]; then
        echo "simx: creating the Python environment $VENV ..."
        "$python" -m venv "$VENV"
    fi
    # Sizes of a fresh environment, measured with pip's cache off (2026-11-24, a fast connection):
    # simx alone 413 MB in 28 s, with the test extra 559 MB in 19-28 s, with the train extra and
    # PyTorch's CPU build 1,386 MB in about 60 s; the ray extra adds Ray and RLlib to that. coal (exact
    # collision queries, a base dependency since) adds 320 MB: simx alone 731 MB (2026-11-25).
    local size="about 730 MB; 20-40 s"
    case "$*" in
    *ray*) size="about 1.7 GB with PyTorch's CPU build, more with Ray; a minute or two" ;;
    *train*) size="about 1.7 GB with PyTorch's CPU build; about a minute" ;;
    *test*) size="about 880 MB; 20-40 s" ;;
    esac
    echo "simx: installing the Python packages ($*) into $VENV: the first time this downloads" \
         "MuJoCo, Zenoh, OpenCV and the rest ($size on a fast connection, minutes on a slow one);" \
         "later runs skip this step until pyproject.toml changes ..."
    local arg
    for arg in "$@"; do
        case "$arg" in
        torch==*+cpu)
            "$VENV/bin/python" -m pip install --quiet --disable-pip-version-check "$arg" 2>/dev/null || {
                echo "simx: $arg from PyTorch's CPU index $TORCH_INDEX ..."
                "$VENV/bin/python" -m pip install --quiet --disable-pip-version-check --index-url "$TORCH_INDEX" "$arg"
            } ;;
        esac
    done
    "$VENV/bin/python" -m pip install --quiet --disable-pip-version-check "$@"
    echo "$want" > "$stamp"
    echo "simx: Python packages installed in $((SECONDS - start)) s."
}

# The test environment, as scripts/test.sh and scripts/check.sh both make it (one install, one
# stamp): the extras in SIMX_TEST_EXTRAS (default "test"), PyTorch's CPU build when they include
# train or ray (as scripts/install-train.sh installs it for a user), and SIMX_PIP_ARGS.
ensure_test_venv() {
    local extras="${SIMX_TEST_EXTRAS:-test}"
    local torch=()
    case ",$extras," in *,train,* | *,ray,*) torch=("$TORCH_CPU") ;; esac
    # shellcheck disable=SC2086  # SIMX_PIP_ARGS: words on purpose
    ensure_venv -e "$ROOT[$extras]" ${torch[@]+"${torch[@]}"} ${SIMX_PIP_ARGS:-}
}
