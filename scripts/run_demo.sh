#!/usr/bin/env bash
# bash scripts/run_demo.sh [DEMO_ARGS...]: on a fresh machine (Python 3.11 + PyPI),
# sets up .venv and runs `flight-sim-dynamics demo -o out/demo.png` (see --help).
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/_setup_env.sh" requirements.txt

# this run's ROS 2 graph to itself
export ROS_DOMAIN_ID="${ROS_DOMAIN_ID:-$((RANDOM % 100 + 1))}"
export ROS_AUTOMATIC_DISCOVERY_RANGE="${ROS_AUTOMATIC_DISCOVERY_RANGE:-LOCALHOST}"
mkdir -p out
exec flight-sim-dynamics demo -o out/demo.png "$@"
