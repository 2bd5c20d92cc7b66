#!/usr/bin/env bash
# Install the Debian/Ubuntu system packages this project needs, only where missing.
#
# Usage: scripts/system-deps.sh [--with-x]
#
#   (no option)  GL libraries for MuJoCo's offscreen renderer on the CPU:
#                MUJOCO_GL=egl with Mesa's llvmpipe (libegl1, libegl-mesa0,
#                libgl1, libglx-mesa0, libgl1-mesa-dri), iproute2 (`ip`, for
#                the network-namespace test tests/transport/test_netns.py), plus
#                python3-venv when `python3 -m venv --help` fails.
#   --with-x     also Xvfb and xdotool, needed only by the tests that drive a
#                real X window (tests/e2e/xdisplay.py), and the X libraries GLFW
#                opens for simx-viewer's window (libx11-6, libxrandr2,
#                libxinerama1, libxcursor1, libxi6).
#
# Presence is checked with dpkg-query; if anything is missing it runs
# `apt-get update` once and `apt-get install -y --no-install-recommends ...`,
# through sudo when not root. Prints one line when everything is present.
# Safe to run repeatedly: a second run installs nothing.
set -euo pipefail

with_x=0
for arg in "$@"; do
    case "$arg" in
        --with-x) with_x=1 ;;
        -h|--help)
            sed -n '2,19p' "$0" | sed 's/^# \{0,1\}//'
            exit 0
            ;;
        *)
            echo "system-deps.sh: unknown argument: $arg (expected --with-x)" >&2
            exit 2
            ;;
    esac
done

if ! command -v dpkg-query >/dev/null 2>&1 || ! command -v apt-get >/dev/null 2>&1; then
    echo "system-deps.sh: dpkg/apt-get not found; this script supports Debian/Ubuntu only." >&2
    exit 1
fi

# Headless OpenGL through EGL (Mesa llvmpipe software rasterizer).
wanted=(libegl1 libegl-mesa0 libgl1 libglx-mesa0 libgl1-mesa-dri iproute2)
if [ "$with_x" -eq 1 ]; then
    wanted+=(xvfb xdotool)
    # simx-viewer's window (tests/e2e/test_viewer.py): GLFW, bundled with the glfw wheel, opens
    # these X libraries at run time.
    wanted+=(libx11-6 libxrandr2 libxinerama1 libxcursor1 libxi6)
fi

is_installed() {
    # dpkg -s also succeeds for removed-but-not-purged packages, so check the status.
    local status
    status=$(dpkg-query -W -f='${Status}' "$1" 2>/dev/null) || return 1
    [ "$status" = "install ok installed" ]
}

missing=()
for pkg in "${wanted[@]}"; do
    is_installed "$pkg" || missing+=("$pkg")
done

# Xvfb / xdotool might also come from somewhere other than these packages.
if [ "$with_x" -eq 1 ]; then
    filtered=()
    for pkg in ${missing[@]+"${missing[@]}"}; do
        case "$pkg" in
            xvfb) command -v Xvfb >/dev/null 2>&1 || filtered+=("$pkg") ;;
            xdotool) command -v xdotool >/dev/null 2>&1 || filtered+=("$pkg") ;;
            *) filtered+=("$pkg") ;;
        esac
    done
    missing=(${filtered[@]+"${filtered[@]}"})
fi

if command -v python3 >/dev/null 2>&1 && ! python3 -m venv --help >/dev/null 2>&1; then
    missing+=(python3-venv)
fi

if [ "${#missing[@]}" -eq 0 ]; then
    if [ "$with_x" -eq 1 ]; then
        echo "system-deps.sh: all system packages present (GL/EGL, iproute2, python3-venv, Xvfb, xdotool)."
    else
        echo "system-deps.sh: all system packages present (GL/EGL, iproute2, python3-venv)."
    fi
    exit 0
fi

if [ "$(id -u)" -eq 0 ]; then
    sudo=()
elif command -v sudo >/dev/null 2>&1; then
    sudo=(sudo)
else
    echo "system-deps.sh: need root to install: ${missing[*]}" >&2
    echo "system-deps.sh: run this script as root or install sudo." >&2
    exit 1
fi

echo "system-deps.sh: installing: ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
"${sudo[@]+"${sudo[@]}"}" env DEBIAN_FRONTEND=noninteractive apt-get update -q
"${sudo[@]+"${sudo[@]}"}" env DEBIAN_FRONTEND=noninteractive \
    apt-get install -y -q --no-install-recommends "${missing[@]}"
echo "system-deps.sh: done."
