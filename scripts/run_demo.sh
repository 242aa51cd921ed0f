#!/usr/bin/env bash
# Run the demo on a fresh machine (only Python 3.11 + PyPI needed):
#   bash scripts/run_demo.sh
# Creates/reuses .venv, installs requirements.txt and the package, then for
# each example motion (vertical, rectilinear, general) generates the motion,
# solves the inverse dynamics and plots it: out/<name>.csv,
# out/<name>_solved.csv and out/<name>.png.
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/_setup_env.sh" requirements.txt

mkdir -p out
for example in vertical rectilinear general; do
    echo "[demo] $example"
    flight-sim-dynamics example "$example" -o "out/$example.csv"
    flight-sim-dynamics solve "out/$example.csv" -o "out/${example}_solved.csv"
    flight-sim-dynamics plot "out/${example}_solved.csv" -o "out/$example.png"
done
echo "[demo] outputs in $(pwd)/out"
