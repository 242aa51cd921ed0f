#!/usr/bin/env bash
# Run the tests on a fresh machine (only Python 3.11 + PyPI needed): creates or
# reuses .venv, installs requirements-test.txt and the package, runs
# `python -m pytest -q ARGS` and exits with pytest's code (5: nothing collected).
#   bash scripts/run_tests.sh                              everything (CI)
#   bash scripts/run_tests.sh -m "not ros and not slow"    the unit tier
#   bash scripts/run_tests.sh test/core                    one folder
# (no path given: test/; tiers: setup.cfg and test/conftest.py; FSD_SKIP_INSTALL=1: no pip)
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/_setup_env.sh" requirements-test.txt

# this run's ROS 2 graph to itself (a random domain in 1..100 unless given)
export ROS_DOMAIN_ID="${ROS_DOMAIN_ID:-$((RANDOM % 100 + 1))}"
export ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST
echo "[tests] ROS_DOMAIN_ID=$ROS_DOMAIN_ID ROS_AUTOMATIC_DISCOVERY_RANGE=$ROS_AUTOMATIC_DISCOVERY_RANGE"

# a failed kernel build fails the run (FSD_REQUIRE_KERNEL=0 allows it)
export FSD_REQUIRE_KERNEL="${FSD_REQUIRE_KERNEL:-1}"

exec python -m pytest -q "$@"
