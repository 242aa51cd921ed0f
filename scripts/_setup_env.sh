# shellcheck shell=bash
# Shared set-up of scripts/run_tests.sh and scripts/run_demo.sh, sourced:
#   source "$(dirname "${BASH_SOURCE[0]}")/_setup_env.sh" REQUIREMENTS_FILE
# Creates (or reuses) .venv at the repository root with Python 3.11, installs
# REQUIREMENTS_FILE (pinned) and this package (`pip install .`), puts the venv
# first on PATH and leaves the caller in the repository root.
#   PYTHON=/path/to/python3.11  interpreter for .venv (default python3.11)
#   FSD_SKIP_INSTALL=1          reuse .venv as it is (no pip; fast re-runs)
# Not `pip install -e .`: editable wheels drop `data_files` (package.xml, the
# ament index marker, config/*.yaml under .venv/share/flight_sim_dynamics).
# The tests import the source tree (`python -m pytest` puts the root first on
# sys.path); reinstalling on every run keeps the console scripts current.

if [ "$#" -ne 1 ]; then
    echo "_setup_env.sh: usage: source _setup_env.sh REQUIREMENTS_FILE" >&2
    return 2
fi

FSD_ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
FSD_VENV="$FSD_ROOT/.venv"
# Bootstrap tools, pinned like requirements*.txt: pip >= 23.1 always builds
# through a wheel (an older pip, e.g. Ubuntu 22.04's, runs `setup.py install`,
# which honours setup.cfg's install_scripts and would put the console scripts in
# .venv/lib/flight_sim_dynamics instead of .venv/bin); setuptools < 80 is what
# colcon-core accepts, and >= 70.1 builds wheels without the `wheel` package.
FSD_BOOTSTRAP="pip==26.3 setuptools==79.0.1"
cd "$FSD_ROOT"

# A sourced ROS 2 install (e.g. /opt/ros/jazzy, built for the system Python)
# would leak its Python packages and shared libraries into the venv's Python
# 3.11 and break rclpy: the venv is self-contained, so drop them for this run.
if [ -n "${ROS_DISTRO:-}" ] || [ -n "${AMENT_PREFIX_PATH:-}" ]; then
    echo "[setup] note: a sourced ROS environment was found (ROS_DISTRO=${ROS_DISTRO:-}); ignoring its PYTHONPATH, LD_LIBRARY_PATH, AMENT_PREFIX_PATH and CMAKE_PREFIX_PATH here: .venv is self-contained" >&2
    unset PYTHONPATH LD_LIBRARY_PATH AMENT_PREFIX_PATH CMAKE_PREFIX_PATH COLCON_PREFIX_PATH ROS_DISTRO ROS_VERSION ROS_PYTHON_VERSION
fi

# Run a set-up step, saying what it is and, while it runs, how long it has
# taken every 10 s (the first install downloads wheels for 1-2 minutes and
# pip --quiet prints nothing meanwhile).
fsd_step() {
    local what="$1"; shift
    local start=$SECONDS
    echo "[setup] $what ..."
    "$@" &
    local pid=$!
    while kill -0 "$pid" 2>/dev/null; do
        sleep 1
        if kill -0 "$pid" 2>/dev/null && [ $(((SECONDS - start) % 10)) -eq 0 ] \
                && [ $((SECONDS - start)) -gt 0 ]; then
            echo "[setup]   ... $what: $((SECONDS - start)) s"
        fi
    done
    local rc=0
    wait "$pid" || rc=$?
    [ "$rc" -eq 0 ] && echo "[setup]   $what: done in $((SECONDS - start)) s"
    return "$rc"
}

fsd_setup_start=$SECONDS
if [ ! -e "$FSD_VENV/bin/python" ]; then
    fsd_python="${PYTHON:-python3.11}"
    if ! command -v "$fsd_python" >/dev/null 2>&1; then
        echo "[setup] error: '$fsd_python' not found; install Python 3.11 or set PYTHON=/path/to/python3.11" >&2
        return 1
    fi
    echo "[setup] creating $FSD_VENV with $("$fsd_python" --version 2>&1)"
    "$fsd_python" -m venv "$FSD_VENV"
fi
if ! "$FSD_VENV/bin/python" -c 'import sys; sys.exit(sys.version_info[:2] != (3, 11))'; then
    echo "[setup] warning: $FSD_VENV is not Python 3.11; the pinned ROS 2 wheels may not install" >&2
fi

if [ "${FSD_SKIP_INSTALL:-0}" = 1 ]; then
    echo "[setup] FSD_SKIP_INSTALL=1: using $FSD_VENV as it is"
else
    echo "[setup] installing $1 and flight_sim_dynamics into $FSD_VENV ..."
    if ! "$FSD_VENV/bin/python" -c 'import sys
from importlib.metadata import version
sys.exit(any(version(n) != v for n, v in (s.split("==") for s in sys.argv[1].split())))' \
            "$FSD_BOOTSTRAP" 2>/dev/null; then
        # shellcheck disable=SC2086
        fsd_step "pinning pip and setuptools" \
            "$FSD_VENV/bin/python" -m pip install --quiet --disable-pip-version-check $FSD_BOOTSTRAP
    fi
    fsd_step "installing the pinned wheels of $1 (1-2 min the first time)" \
        "$FSD_VENV/bin/python" -m pip install --quiet --disable-pip-version-check -r "$1"
    # setuptools reuses build/lib between builds, so a module deleted from the
    # sources would still be shipped: start the wheel build from scratch.
    rm -rf "$FSD_ROOT/build/lib" "$FSD_ROOT"/build/bdist.*
    # --no-build-isolation: build with the venv's pinned setuptools instead of
    # fetching the latest one into a throw-away environment (3-6 s instead of
    # 12-14 s per run, and no network once the venv is complete).
    fsd_step "installing flight_sim_dynamics (compiles the kernel)" \
        "$FSD_VENV/bin/python" -m pip install --quiet --disable-pip-version-check --no-build-isolation .
    # The compiled kernel (src/kernel.c) next to the sources too, for code run
    # from the source tree (the tests, benchmarks/): a gitignored .so in
    # flight_sim_dynamics/. Without a C compiler both steps leave the kernel
    # out and the package solves with its Python code (FSD_REQUIRE_KERNEL=1
    # turns that into an error, as scripts/run_tests.sh does).
    "$FSD_VENV/bin/python" setup.py --quiet build_ext --inplace >/dev/null 2>&1 \
        || echo "[setup] warning: the compiled kernel did not build (no C compiler?); the Python code will be used" >&2
    echo "[setup] done in $((SECONDS - fsd_setup_start)) s"
fi

export VIRTUAL_ENV="$FSD_VENV"
export PATH="$FSD_VENV/bin:$PATH"
# Plots are written to files: never need a display.
export MPLBACKEND="${MPLBACKEND:-Agg}"
unset fsd_setup_start fsd_python FSD_BOOTSTRAP
unset -f fsd_step
