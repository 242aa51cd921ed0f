"""Scripts that print figures (not installed; run from the repository root):
``python -m benchmarks.solve`` (solve, solve_batch), ``.node`` (round trip next to
a same-traffic echo), ``.twin`` (real-time factor), ``.csv`` (solve end to end).
"""
