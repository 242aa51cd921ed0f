# shellcheck shell=bash
# `source _setup_env.sh REQUIREMENTS_FILE` (run_tests.sh, run_demo.sh): creates or reuses .venv
# (Python 3.11; PYTHON=...), installs REQUIREMENTS_FILE and `pip install .` (not -e: editable
# wheels drop data_files), puts .venv first on PATH, cd's to the root. FSD_SKIP_INSTALL=1: no pip.
[ "$#" -eq 1 ] || { echo "_setup_env.sh: usage: source _setup_env.sh REQUIREMENTS_FILE" >&2; return 2; }

FSD_ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
FSD_VENV="$FSD_ROOT/.venv"
# pip >= 23.1 builds through a wheel (console scripts in .venv/bin); colcon wants setuptools < 80
FSD_BOOTSTRAP="pip==26.3 setuptools==79.0.1"
cd "$FSD_ROOT"

# a sourced ROS 2 install (system Python) would break the venv's rclpy
if [ -n "${ROS_DISTRO:-}" ] || [ -n "${AMENT_PREFIX_PATH:-}" ]; then
    echo "[setup] note: a sourced ROS environment was found (ROS_DISTRO=${ROS_DISTRO:-}); ignoring its PYTHONPATH, LD_LIBRARY_PATH, AMENT_PREFIX_PATH and CMAKE_PREFIX_PATH here: .venv is self-contained" >&2
    unset PYTHONPATH LD_LIBRARY_PATH AMENT_PREFIX_PATH CMAKE_PREFIX_PATH COLCON_PREFIX_PATH ROS_DISTRO ROS_VERSION ROS_PYTHON_VERSION
fi

# a set-up step, with its elapsed time every 10 s (pip --quiet is silent)
fsd_step() {
    local what="$1" start=$SECONDS pid rc=0; shift
    echo "[setup] $what ..."
    "$@" & pid=$!
    while sleep 1 && kill -0 "$pid" 2>/dev/null; do
        if [ $(((SECONDS - start) % 10)) -eq 0 ]; then echo "[setup]   ... $what: $((SECONDS - start)) s"; fi
    done
    wait "$pid" || rc=$?
    if [ "$rc" -eq 0 ]; then echo "[setup]   $what: done in $((SECONDS - start)) s"; fi
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
    # shellcheck disable=SC2086
    fsd_step "pinning pip and setuptools" \
        "$FSD_VENV/bin/python" -m pip install --quiet --disable-pip-version-check $FSD_BOOTSTRAP
    fsd_step "installing the pinned wheels of $1 (1-2 min the first time)" \
        "$FSD_VENV/bin/python" -m pip install --quiet --disable-pip-version-check -r "$1"
    # a stale build/lib would ship deleted modules
    rm -rf "$FSD_ROOT/build/lib" "$FSD_ROOT"/build/bdist.*
    # --no-build-isolation: the venv's pinned setuptools, no network
    fsd_step "installing flight_sim_dynamics (compiles the kernel)" \
        "$FSD_VENV/bin/python" -m pip install --quiet --disable-pip-version-check --no-build-isolation .
    # the kernel in the source tree too, for the tests and benchmarks (gitignored)
    "$FSD_VENV/bin/python" setup.py --quiet build_ext --inplace >/dev/null 2>&1 \
        || echo "[setup] warning: the compiled kernel did not build (no C compiler?); the Python code will be used" >&2
    echo "[setup] done in $((SECONDS - fsd_setup_start)) s"
fi

export VIRTUAL_ENV="$FSD_VENV"
export PATH="$FSD_VENV/bin:$PATH"
export MPLBACKEND="${MPLBACKEND:-Agg}"
unset fsd_setup_start fsd_python FSD_BOOTSTRAP
unset -f fsd_step
