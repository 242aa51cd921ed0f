#!/usr/bin/env bash
# `python -m pytest -q -n 2 ARGS` in .venv (created, requirements-test.txt and the package
# installed; FSD_SKIP_INSTALL=1: no pip), e.g. no ARGS: everything (CI);
# -m "not ros and not slow": the unit tier (setup.cfg); test/core: one folder.
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/_setup_env.sh" requirements-test.txt

# this run's ROS 2 graph to itself (a random domain in 1..100 unless given)
export ROS_DOMAIN_ID="${ROS_DOMAIN_ID:-$((RANDOM % 100 + 1))}"
export ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST
echo "[tests] ROS_DOMAIN_ID=$ROS_DOMAIN_ID ROS_AUTOMATIC_DISCOVERY_RANGE=$ROS_AUTOMATIC_DISCOVERY_RANGE"

# a failed kernel build fails the run (FSD_REQUIRE_KERNEL=0 allows it)
export FSD_REQUIRE_KERNEL="${FSD_REQUIRE_KERNEL:-1}"

# one process by default: the node tests measure real time (a twin keeping up, a
# stream answered), which two test files side by side on two cores miss.
# FSD_TEST_WORKERS=2: two workers (pytest-xdist), a test file to one worker, each
# in its own ROS domain (test/conftest.py): the unit tier in about half the time
exec python -m pytest -q -n "${FSD_TEST_WORKERS:-0}" --dist loadfile "$@"
