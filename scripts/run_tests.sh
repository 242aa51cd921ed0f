#!/usr/bin/env bash
# Run the tests on a fresh machine (only Python 3.11 + PyPI needed):
#   bash scripts/run_tests.sh [PYTEST_ARGS...]
# Creates/reuses .venv, installs requirements-test.txt and the package, then
# runs `python -m pytest -q PYTEST_ARGS` and exits with pytest's exit code
# (5 = no tests collected counts as a failure). Without a path in the
# arguments pytest runs test/ (setup.cfg's testpaths), e.g.
#   bash scripts/run_tests.sh                              everything (CI)
#   bash scripts/run_tests.sh -m "not ros and not slow"    the unit tier
#   bash scripts/run_tests.sh test/core                    one folder
# (markers: setup.cfg and test/conftest.py; FSD_SKIP_INSTALL=1 skips pip.)
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/_setup_env.sh" requirements-test.txt

# Isolate the ROS 2 graph of this run: the ROS_DOMAIN_ID the caller set, else a
# random one in 1..100 (inside Fast DDS's default port range), and discovery
# limited to this machine, so parallel runs and other robots on the network do
# not see each other.
ROS_DOMAIN_ID="${ROS_DOMAIN_ID:-$((RANDOM % 100 + 1))}"
export ROS_DOMAIN_ID
export ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST
echo "[tests] ROS_DOMAIN_ID=$ROS_DOMAIN_ID ROS_AUTOMATIC_DISCOVERY_RANGE=$ROS_AUTOMATIC_DISCOVERY_RANGE"

# The compiled kernel must be there: a failed build fails the run instead of
# quietly testing the Python fallback only (FSD_REQUIRE_KERNEL=0 to allow it;
# FSD_KERNEL=0 runs the whole suite on the Python code, see test/conftest.py).
export FSD_REQUIRE_KERNEL="${FSD_REQUIRE_KERNEL:-1}"

exec python -m pytest -q "$@"
