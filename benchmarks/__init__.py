"""Benchmarks and measurement tools of flight_sim_dynamics (not installed).

Run from the repository root, each as a module::

    python -m benchmarks.performance [--quick] [--out out/performance.md]
    python -m benchmarks.bench_node [--rates 200 1000] [--echo]
    python -m benchmarks.bench_callbacks [--setpoints 5000]
    python -m benchmarks.estimation [--rates 50 100 200] [--markdown]
    python -m benchmarks.twin [--bandwidth 5] [--quick] [--update-docs]

They print and write figures and tables; what the figures mean is written
by people (README, docs/).
"""
