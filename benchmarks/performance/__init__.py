"""Performance benchmark of flight_sim_dynamics against the targets of the
performance issue; prints a table and writes a markdown report (``out/performance.md``).

    python -m benchmarks.performance                    # everything (~20 min) -> out/performance.md
    python -m benchmarks.performance --update-docs      # the same, written to docs/performance.md
    python -m benchmarks.performance --quick --no-node --out /tmp/perf.md

Run from the repository root. Modules: ``common`` (targets, verdicts,
states), ``solve`` (sections 1-3), ``node`` (4-5), ``profiles``, ``report``,
``run`` (the command line).

Sections (each figure printed next to its target, the gap when missed, and the
load average of the shared machine when it was taken; no figure is asserted
anywhere):

1. per-cycle ``fsd.solve`` of the scenes ``full`` and ``quasi_static`` in this
   process (median, p99 over ``--cycles`` calls, states cycling through the
   paper's general motion and the motion-cueing sequence; interleaved timing of
   :func:`flight_sim_dynamics.bench.time_cases`), and the cost of ``sol.cond``
   on demand;
2. ``fsd.solve_batch`` throughput on N = ``--batch-n`` samples, and agreement
   batch vs per-cycle;
3. a ``--csv-rows``-row trajectory CSV through ``python -m flight_sim_dynamics
   solve`` as a subprocess (wall time, median of ``--csv-runs``);
4. the node, and a bare rclpy echo, at ``--rate`` Hz for ``--node-seconds`` s
   each, one after the other, each its own process, fed by a driver process
   (``python -m benchmarks.bench_node``): publish -> receipt latency, lost setpoints,
   node/echo ratio; if the node does not keep up, the same at ``--context-rate``;
5. a soak of the node for ``--soak-minutes``: VmRSS every 10 s, lost setpoints,
   the /diagnostics solve-time figures per period;

plus profiles: the parts of ``fsd.solve`` (compiled kernel, wrapper, and the
Python reference code for comparison), the batch with one and all threads,
and the node under load (py-spy if installed, and/or
cProfile of the node process). rclpy is imported only by the node/echo/driver
processes, never by this one.
"""

from .node import _flat, _minute_r, _timing_key, section_executors, section_node, section_soak
from .profiles import _short
from .report import markdown
from .run import main, parse_args

__all__ = ['main', 'parse_args', 'markdown', 'section_node', 'section_executors',
           'section_soak', '_flat', '_minute_r', '_timing_key', '_short']
