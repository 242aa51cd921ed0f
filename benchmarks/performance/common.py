"""Targets, verdicts, the summary table and the measured states (shared by
the sections of the performance benchmark).
"""
from __future__ import annotations

import functools
import math
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Sequence

import numpy as np

from flight_sim_dynamics.core.motions import PlannerSequence

from .. import node_stream

#: The repository root (cwd of the processes started, git state of the report).
ROOT = Path(__file__).resolve().parents[2]

# ----------------------------------------------------------------------------
# Targets (the issue)
# ----------------------------------------------------------------------------
TARGET_SOLVE_MEDIAN_US = 30.0
TARGET_SOLVE_P99_US = 60.0
TARGET_QS_US = 10.0
TARGET_BATCH_PER_S = 500_000.0
TARGET_CSV_S = 2.0
TARGET_NODE_MEDIAN_MS = 0.5
TARGET_NODE_P99_MS = 1.5
TARGET_NODE_ECHO_RATIO = 1.3
TARGET_RSS_GROWTH_MB = 2.0
ROUND_OFF_N = 1e-9          # "agree to round-off": forces of ~50 N, 1e-9 N = 2e-11 relative
SOAK_BASELINE_S = 10.0      # RSS growth measured from the sample this far into the soak

#: Where the report goes: out/ unless --out or --update-docs says otherwise.
DEFAULT_OUT = Path('out') / 'performance.md'
DOCS_OUT = ROOT / 'docs' / 'performance.md'


def log(msg: str) -> None:
    print(f'[performance {time.strftime("%H:%M:%S")}] {msg}', file=sys.stderr, flush=True)


def load1() -> float:
    return node_stream.load_average()[0]


# ----------------------------------------------------------------------------
# The summary table
# ----------------------------------------------------------------------------
@dataclass
class Row:
    section: str
    figure: str
    measured: str
    target: str
    verdict: str
    load: float

    @property
    def missed(self) -> bool:
        return self.verdict.startswith('MISSED')


def at_most(value: float, target: float, unit: str, fmt: str = '{:.1f}') -> str:
    """Verdict for a figure that must be <= target."""
    if not math.isfinite(value):
        return 'not measured'
    if value <= target:
        return f'met ({value / target:.2f} of the target)'
    return (f'MISSED: {value / target:.1f}x over ({fmt.format(value)} vs {fmt.format(target)} '
            f'{unit})')


def at_least(value: float, target: float, unit: str, fmt: str = '{:.0f}') -> str:
    """Verdict for a figure that must be >= target."""
    if not math.isfinite(value):
        return 'not measured'
    if value >= target:
        return f'met ({value / target:.2f}x the target)'
    return (f'MISSED: {target / value:.1f}x under ({fmt.format(value)} vs {fmt.format(target)} '
            f'{unit}; needs {target / value:.1f}x faster)')


def none_lost(lost: int, sent: int) -> str:
    if lost == 0:
        return 'met'
    return f'MISSED: {lost} of {sent} lost ({100.0 * lost / sent:.2f} %)'


def table(header: Sequence[str], rows: Sequence[Sequence[str]],
          align: Sequence[str] | None = None) -> str:
    align = align or ['l'] + ['r'] * (len(header) - 1)
    sep = ['---:' if a == 'r' else ':---' for a in align]
    out = ['| ' + ' | '.join(header) + ' |', '| ' + ' | '.join(sep) + ' |']
    out += ['| ' + ' | '.join(str(c) for c in r) + ' |' for r in rows]
    return '\n'.join(out)


def summary_table(rows: Sequence[Row]) -> str:
    return table(['#', 'figure', 'measured', 'target', 'verdict', 'load avg (1 min)'],
                 [[r.section, r.figure, r.measured, r.target, r.verdict,
                   f'{r.load:.2f}' if math.isfinite(r.load) else '-'] for r in rows],
                 ['l', 'l', 'r', 'r', 'l', 'r'])


# ----------------------------------------------------------------------------
# States
# ----------------------------------------------------------------------------
@functools.lru_cache(maxsize=4)
def sequence_states(rate: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One period of the paper's general motion, its return to neutral and the
    motion-cueing sequence (the node benchmark's stream), at ``rate`` Hz.
    """
    return PlannerSequence(['general', 'cueing'], loop=True).states(rate)


def as_states(q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> list[tuple]:
    """Plain-float (q, qd, qdd) tuples, as a node hands them to fsd.solve."""
    return [(tuple(a), tuple(b), tuple(c))
            for a, b, c in zip(q.tolist(), qd.tolist(), qdd.tolist())]


def tiled(arrays: Sequence[np.ndarray], n: int) -> list[np.ndarray]:
    reps = n // len(arrays[0]) + 1
    return [np.tile(a, (reps, 1))[:n] for a in arrays]



def fmt(x: float, digits: int = 2) -> str:
    return f'{x:.{digits}f}' if math.isfinite(x) else '-'

