#!/usr/bin/env bash
# `python -m pytest -q -n 3 -m "not slow" ARGS` in .venv (created, requirements-test.txt
# and the package installed; FSD_SKIP_INSTALL=1: no pip), e.g. no ARGS: the unit and
# ros tiers; -m slow: the slow tier (CI runs both); -m "not ros and not slow": the
# unit tier (setup.cfg); test/core: one folder.
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/_setup_env.sh" requirements-test.txt

# this run's ROS 2 graph to itself (a random domain in 1..100 unless given)
export ROS_DOMAIN_ID="${ROS_DOMAIN_ID:-$((RANDOM % 100 + 1))}"
export ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST
echo "[tests] ROS_DOMAIN_ID=$ROS_DOMAIN_ID ROS_AUTOMATIC_DISCOVERY_RANGE=$ROS_AUTOMATIC_DISCOVERY_RANGE"

# bytecode cached (gitignored __pycache__): with PYTHONDONTWRITEBYTECODE set, every
# worker and every process a test starts compiled the test modules and the
# source tree again (collection: 6.9 s -> 3.4 s a process)
unset PYTHONDONTWRITEBYTECODE

# a failed kernel build fails the run (FSD_REQUIRE_KERNEL=0 allows it)
export FSD_REQUIRE_KERNEL="${FSD_REQUIRE_KERNEL:-1}"

# the tiers: without a -m of its own, the unit and ros tiers (not the slow one,
# which CI runs as `bash scripts/run_tests.sh -m slow`)
marker=(-m "not slow")
for arg in "$@"; do
    case "$arg" in -m|-m*) marker=() ;; esac
done

# three workers (pytest-xdist) by default (FSD_TEST_WORKERS=0: one process), on
# two cores too: the ros tier waits on real time (streams, discovery) about half
# of its run, so a third worker fills it (beside two busy loops on 2 cores: 6:35
# on two workers, 5:05 on three). A test file stays on one worker, so a module's
# node is started once; each worker has its own ROS domain (test/conftest.py).
# The node tests check what holds on a busy host (every setpoint answered, a
# twin following within a delay), not how fast it happens.
exec python -m pytest -q -n "${FSD_TEST_WORKERS:-3}" --dist loadfile "${marker[@]}" "$@"
