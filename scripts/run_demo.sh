#!/usr/bin/env bash
# The main job on a fresh machine (only Python 3.11 + PyPI needed):
#   bash scripts/run_demo.sh [DEMO_ARGS...]
# Creates/reuses .venv, installs requirements.txt and the package, then runs
# `flight-sim-dynamics demo`: the node (dynamics_node, a separate process, with
# the packaged parameter file) next to the built-in demo planner streaming the
# paper's three motions and a motion-cueing sequence; one summary line per
# second; at the end out/demo.png, the forces and powers recorded from the
# published actuator_states. Extra arguments go to the demo (see --help).
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/_setup_env.sh" requirements.txt

# Keep this run's ROS 2 graph to itself (same as scripts/run_tests.sh).
export ROS_DOMAIN_ID="${ROS_DOMAIN_ID:-$((RANDOM % 100 + 1))}"
export ROS_AUTOMATIC_DISCOVERY_RANGE="${ROS_AUTOMATIC_DISCOVERY_RANGE:-LOCALHOST}"
mkdir -p out
exec flight-sim-dynamics demo -o out/demo.png "$@"
