"""Scripts that print figures (not installed; run from the repository root).

python -m benchmarks.solve     # solve us per call, solve_batch us per sample
python -m benchmarks.node      # the node's round trip next to a same-traffic echo
python -m benchmarks.twin      # the twin's real-time factor (--out PNG: tracking figure)
python -m benchmarks.csv       # flight-sim-dynamics solve end to end
"""
