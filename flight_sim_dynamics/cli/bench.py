"""What accuracy costs in time: ``flight-sim-dynamics bench``.

For every packaged scene and for the single-effect variants of the ``full``
model (``full`` without one of its effects, ``full`` with friction) this
measures

* the time of one control cycle, :func:`flight_sim_dynamics.solve` in this
  process (median and 99th percentile over ``--cycles`` calls, states cycled
  through the samples of the four test motions), and the throughput of
  :func:`flight_sim_dynamics.solve_batch` (samples per second);
* the actuator-force error against the ``full`` model (maximum and RMS over
  the samples and the three legs, in N and in % of the full model's peak
  |force| on that motion) on the paper's three motions and on a violent
  motion-cueing-like motion (:func:`violent_motion`);

and the accuracy cost of not receiving accelerations (estimated by the node's
:class:`~flight_sim_dynamics.setpoints.DerivativeEstimator` from exact twists,
or rates and accelerations both from poses, sampled at 60, 250 and 1000 Hz),
plus the other speed/accuracy trades the solver offers (the ``cond(Q)``
diagnostic, ``solve_batch`` on one sample). It prints the tables and writes
``<out-dir>/scenes.md`` and ``<out-dir>/scenes.png`` (time per cycle against
force error, one point per variant).

Timing method: the timed cases (variants) are interleaved call by call, in
an order shuffled anew for each state, so background load on a shared
machine hits all of them alike; each call is timed alone with
``time.perf_counter_ns``; the differences to ``full`` are medians of the
differences of per-block medians (blocks of ``--block`` states, paired), with
a sign test over the blocks. No rclpy needed.
"""
from __future__ import annotations

import argparse
import datetime
import gc
import io
import math
import os
import platform
import random
import shlex
import sys
import time
from dataclasses import dataclass, field, replace
from functools import partial
from typing import Callable, Sequence

import numpy as np

import flight_sim_dynamics as fsd

from ..core import kernel
from ..core.cueing import step_sequence
from ..core.model import Model
from ..ros.estimator import ESTIMATORS, DerivativeEstimator
from ..core.trajectories import DURATION as PAPER_DURATION
from ..core.trajectories import PAPER_EXAMPLES, paper_example

# ----------------------------------------------------------------------------
# The violent motion
# ----------------------------------------------------------------------------
#: (coordinate, start s, duration s, change) of each quintic smooth step of the
#: violent motion: 0 = surge (m), 1 = heave (m), 2 = roll (rad). The
#: motion-cueing sequence of :mod:`.cueing` compressed into short, overlapping
#: onset cues (peak quintic acceleration = 5.77 change / duration^2) and their
#: washouts; it starts and ends at rest in the central configuration.
VIOLENT_STEPS: tuple[tuple[int, float, float, float], ...] = (
    (0, 0.00, 0.20, +0.08),   # surge onset, 11.5 m/s^2
    (2, 0.10, 0.26, +0.25),   # roll onset, 21 rad/s^2
    (1, 0.30, 0.18, +0.06),   # heave bump up, 10.7 m/s^2
    (0, 0.40, 0.60, -0.08),   # surge washout
    (1, 0.48, 0.25, -0.12),   # ... and straight down through neutral, 11 m/s^2
    (2, 0.60, 0.35, -0.45),   # roll reversal to -0.2 rad, 21 rad/s^2
    (1, 0.90, 0.40, +0.06),   # heave back to neutral
    (0, 1.20, 0.16, -0.05),   # surge braking jolt, 11 m/s^2
    (2, 1.20, 0.60, +0.20),   # roll washout to level
    (1, 1.40, 0.13, +0.03),   # runway bump up, 10 m/s^2 ...
    (1, 1.53, 0.13, -0.03),   # ... and down
    (0, 1.50, 1.00, +0.05),   # surge washout
    (2, 2.00, 0.20, -0.15),   # roll kick, 21 rad/s^2 ...
    (2, 2.20, 0.60, +0.15),   # ... washed out
)
VIOLENT_DURATION = 3.0  # s; at rest in the central configuration from 2.8 s on

MOTIONS = (*PAPER_EXAMPLES, 'violent')


def _us(x: float) -> str:
    """Microseconds for the text: 0.1 us resolution below 10 us (the compiled
    solve takes a few), whole ones above."""
    return f'{x:.1f}' if abs(x) < 10.0 else f'{x:.0f}'



def violent_motion(t: np.ndarray | float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """q, qd, qdd (each (N, 3)) of the violent motion at times ``t`` (s):
    exact derivatives of the sum of the smooth steps :data:`VIOLENT_STEPS`."""
    return step_sequence(VIOLENT_STEPS, t)


def motion(name: str, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """q, qd, qdd of a test motion: a paper example or ``violent``."""
    if name == 'violent':
        return violent_motion(t)
    return paper_example(name, t)


def motion_duration(name: str) -> float:
    return VIOLENT_DURATION if name == 'violent' else PAPER_DURATION


def sample_times(duration: float, rate_hz: float) -> np.ndarray:
    """0, 1/rate, ..., duration (inclusive when on the grid)."""
    return np.arange(int(math.floor(duration * rate_hz + 1e-9)) + 1) / rate_hz


# ----------------------------------------------------------------------------
# Variants
# ----------------------------------------------------------------------------
REFERENCE, SCENE, DROPS, ADDS = 'reference', 'scene', 'drops', 'adds'


@dataclass(frozen=True)
class Variant:
    key: str          # short name used in tables and on the plot
    kind: str         # REFERENCE, SCENE (a packaged scene), DROPS or ADDS (vs full)
    model: Model
    description: str


def variants() -> list[Variant]:
    """The packaged scenes, then ``full`` without each of its effects, then
    ``full`` with each effect it lacks that adds no body (friction)."""
    from ..config.scenes import available_scenes, load_scene

    full = fsd.load_model(scene='full')
    out = [Variant('full', REFERENCE, full, load_scene('full').description)]
    for name in available_scenes():
        if name == 'full':
            continue
        model = fsd.load_model(scene=name)
        extra = set(model.effects.enabled()) - set(full.effects.enabled())
        kind = ADDS if extra else SCENE
        out.append(Variant(name, kind, model, load_scene(name).description))
    for effect in full.effects.enabled():
        out.append(Variant(f'full - {effect}', DROPS,
                           full.with_effects(full.effects.without(effect),
                                             scene=f'full_without_{effect}'),
                           f'full model without {effect}'))
    for effect in ('friction',):
        if not getattr(full.effects, effect):
            fr = full.friction
            what = (f'actuator friction (viscous {_fmt_list(fr.viscous)} N s/m, Coulomb '
                    f'{_fmt_list(fr.coulomb)} N, legs A, B, C)' if effect == 'friction'
                    else effect)
            out.append(Variant(f'full + {effect}', ADDS,
                               full.with_effects(replace(full.effects, **{effect: True}),
                                                 scene=f'full_with_{effect}'),
                               f'full model plus {what}'))
    return out


def _fmt_list(values: Sequence[float]) -> str:
    values = [float(x) for x in values]
    return f'{values[0]:g}' if len(set(values)) == 1 else '/'.join(f'{x:g}' for x in values)


# ----------------------------------------------------------------------------
# Force errors
# ----------------------------------------------------------------------------
@dataclass(frozen=True)
class ForceError:
    max: float        # N, over samples and legs
    rms: float        # N, over samples and legs
    peak: float       # N, peak |force| of the reference on the motion

    @property
    def max_pct(self) -> float:
        return 100.0 * self.max / self.peak

    @property
    def rms_pct(self) -> float:
        return 100.0 * self.rms / self.peak


def force_error(force: np.ndarray, reference: np.ndarray, peak: float | None = None
                ) -> ForceError:
    diff = np.asarray(force, dtype=float) - np.asarray(reference, dtype=float)
    peak = float(np.abs(reference).max()) if peak is None else peak
    return ForceError(max=float(np.abs(diff).max()), rms=float(np.sqrt(np.mean(diff ** 2))),
                      peak=peak)


@dataclass
class MotionSet:
    """The exact test motions sampled at ``rate`` Hz, and the full model's forces."""

    rate: float
    q: dict[str, np.ndarray] = field(default_factory=dict)
    qd: dict[str, np.ndarray] = field(default_factory=dict)
    qdd: dict[str, np.ndarray] = field(default_factory=dict)
    force: dict[str, np.ndarray] = field(default_factory=dict)   # full model
    peak: dict[str, float] = field(default_factory=dict)


def motion_set(full: Model, rate: float) -> MotionSet:
    ms = MotionSet(rate)
    for name in MOTIONS:
        q, qd, qdd = motion(name, sample_times(motion_duration(name), rate))
        try:
            sol = fsd.solve_batch(full, q, qd, qdd)
        except fsd.UnreachablePoseError as exc:   # pragma: no cover - a bad motion table
            raise ValueError(f'test motion {name!r} is not reachable: {exc}') from None
        bad = [str(s) for s in np.atleast_1d(getattr(sol, 'status', []))
               if str(s) in ('unreachable', 'invalid_input')]
        if bad:                                   # pragma: no cover - a bad motion table
            raise ValueError(f'test motion {name!r} is not solvable: {bad[0]}')
        force = sol.force
        ms.q[name], ms.qd[name], ms.qdd[name], ms.force[name] = q, qd, qdd, force
        ms.peak[name] = float(np.abs(force).max())
    return ms


def variant_errors(variant: Variant, ms: MotionSet) -> dict[str, ForceError]:
    return {name: force_error(
        fsd.solve_batch(variant.model, ms.q[name], ms.qd[name], ms.qdd[name]).force,
        ms.force[name], ms.peak[name]) for name in MOTIONS}


# ----------------------------------------------------------------------------
# Missing accelerations (and twists): the node's estimator
# ----------------------------------------------------------------------------
ESTIMATOR_RATES = (60.0, 250.0, 1000.0)
ESTIMATOR_MOTIONS = ('general', 'violent')
STARTUP_SAMPLES = 4   # the estimator's history is full (BDF2 of BDF2 rates) from the 5th


@dataclass(frozen=True)
class EstimatorCase:
    source: str                 # 'twist' (exact qd given) or 'pose' (pose only)
    method: str
    rate: float
    steady: dict[str, ForceError]     # samples STARTUP_SAMPLES.. on
    startup_max: dict[str, float]     # max |error| over the first STARTUP_SAMPLES, N


def estimate(method: str, rate: float, name: str, twist: bool
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Feed the node's estimator the samples of motion ``name`` at ``rate`` Hz
    (pose and exact twist, or pose only); returns q, the rates and
    accelerations the node would use, and the exact ones."""
    t = sample_times(motion_duration(name), rate)
    q, qd, qdd = motion(name, t)
    est = DerivativeEstimator(method)
    qd_used = np.empty_like(qd)
    qdd_used = np.empty_like(qdd)
    for k in range(len(t)):
        rates, accs = est.update(float(t[k]), tuple(q[k].tolist()),
                                 tuple(qd[k].tolist()) if twist else None, None)
        qd_used[k] = rates
        qdd_used[k] = accs
    return q, qd_used, qdd_used, qd, qdd


def estimator_cases(full: Model, peaks: dict[str, float],
                    rates: Sequence[float] = ESTIMATOR_RATES) -> list[EstimatorCase]:
    out = []
    for source in ('twist', 'pose'):
        for method in ESTIMATORS:
            for rate in rates:
                steady, startup = {}, {}
                for name in ESTIMATOR_MOTIONS:
                    q, qd_used, qdd_used, qd, qdd = estimate(method, rate, name,
                                                             source == 'twist')
                    f_est = fsd.solve_batch(full, q, qd_used, qdd_used).force
                    f_ref = fsd.solve_batch(full, q, qd, qdd).force
                    k = STARTUP_SAMPLES
                    steady[name] = force_error(f_est[k:], f_ref[k:], peaks[name])
                    startup[name] = float(np.abs(f_est[:k] - f_ref[:k]).max())
                out.append(EstimatorCase(source, method, rate, steady, startup))
    return out


# ----------------------------------------------------------------------------
# Timing
# ----------------------------------------------------------------------------
@dataclass
class Timing:
    """Per-call times (ns) of one timed case and its per-block medians."""

    samples: np.ndarray
    block_medians: np.ndarray
    block_p99s: np.ndarray

    @property
    def median_us(self) -> float:
        return float(np.median(self.samples)) / 1e3

    @property
    def p99_us(self) -> float:
        return float(np.percentile(self.samples, 99)) / 1e3

    @property
    def block_p99_us(self) -> float:
        """Median over the blocks of each block's p99: the tail of a typical
        stretch of cycles, less swayed by a burst of load in one block."""
        return float(np.median(self.block_p99s)) / 1e3

    def paired_delta_us(self, other: 'Timing') -> tuple[float, float]:
        """(median over the blocks of (block median of self - that of ``other``
        in the same round), two-sided sign-test p-value of that difference)."""
        d = (self.block_medians - other.block_medians) / 1e3
        return float(np.median(d)), sign_test(d)


def sign_test(d: np.ndarray) -> float:
    """Two-sided sign-test p-value of paired differences ``d`` against 0."""
    pos, neg = int(np.sum(d > 0)), int(np.sum(d < 0))
    n = pos + neg
    if n == 0:
        return 1.0
    k = max(pos, neg)
    tail = sum(math.comb(n, i) for i in range(k, n + 1)) / 2.0 ** n
    return min(1.0, 2.0 * tail)


#: A time difference is reported as real when the sign test over the blocks
#: gives p below this (and it exceeds 1 % of the full solve).
SIGNIFICANCE = 0.01


@dataclass(frozen=True)
class Case:
    """A timed case: ``fn(*state)`` for each state of ``states`` in turn."""

    fn: Callable
    states: list


def time_cases(cases: dict[str, Case], cycles: int, block: int, warmup: int,
               progress: Callable[[str], None] | None = None) -> dict[str, Timing]:
    """Time every case for ``cycles`` calls, each call timed alone. The cases
    are interleaved call by call (state k: one call of every case, in a random
    order drawn anew for each k, so that no case always follows the same
    other one), so a burst of load from other processes hits them all alike; the statistics are also kept per block of ``block`` states, whose
    medians pair the cases over the same stretch of time."""
    clock = time.perf_counter_ns
    names = list(cases)
    for name in names:                      # warm-up (caches, branch predictors, ...)
        case = cases[name]
        for k in range(warmup):
            case.fn(*case.states[k % len(case.states)])
    fns = [cases[name].fn for name in names]
    states = [cases[name].states for name in names]
    n_cases = len(names)
    rng = random.Random(20130101)           # fixed seed: the same orders every run
    order = list(range(n_cases))
    times: list[list[int]] = [[] for _ in names]
    medians: list[list[float]] = [[] for _ in names]
    p99s: list[list[float]] = [[] for _ in names]
    n_blocks = max(1, math.ceil(cycles / block))
    for b in range(n_blocks):
        n = min(block, cycles - b * block)
        out = [[0] * n for _ in names]
        gc.collect()
        for k in range(n):
            index = b * block + k
            rng.shuffle(order)
            for i in order:
                st = states[i]
                s = st[index % len(st)]
                fn = fns[i]
                t0 = clock()
                fn(*s)
                out[i][k] = clock() - t0
        for i in range(n_cases):
            times[i].extend(out[i])
            medians[i].append(float(np.median(out[i])))
            p99s[i].append(float(np.percentile(out[i], 99)))
        if progress is not None and (b + 1) % max(1, n_blocks // 10) == 0:
            progress(f'timing: block {b + 1}/{n_blocks}')
    return {name: Timing(np.array(times[i], dtype=float), np.array(medians[i]),
                         np.array(p99s[i])) for i, name in enumerate(names)}


def batch_throughput(models: dict[str, Model], Q: np.ndarray, Qd: np.ndarray,
                     Qdd: np.ndarray, repeats: int) -> dict[str, float]:
    """solve_batch samples per second of each model on (Q, Qd, Qdd): N / the
    shortest of ``repeats`` calls (interleaved across the models). Best-of, as
    for timeit: the load of other processes only ever adds time, and a call is
    long (tens of ms), so its median would measure that load."""
    names = list(models)
    for name in names:
        fsd.solve_batch(models[name], Q, Qd, Qdd)          # warm-up
    times = {name: [] for name in names}
    for r in range(repeats):
        shift = r % len(names)
        for name in names[shift:] + names[:shift]:
            gc.collect()
            t0 = time.perf_counter()
            fsd.solve_batch(models[name], Q, Qd, Qdd)
            times[name].append(time.perf_counter() - t0)
    return {name: len(Q) / float(np.min(times[name])) for name in names}


class _EstimatorCall:
    """One :meth:`DerivativeEstimator.update` per call, at a steady ``rate``."""

    def __init__(self, method: str, rate: float, twist: bool) -> None:
        self.est = DerivativeEstimator(method)
        self.dt = 1.0 / rate
        self.t = 0.0
        self.twist = twist

    def __call__(self, q, qd, qdd) -> None:
        self.t += self.dt
        self.est.update(self.t, q, qd if self.twist else None, None)


def _solve_cond(model: Model, q, qd, qdd) -> float:
    return fsd.solve(model, q, qd, qdd).cond


# ----------------------------------------------------------------------------
# Report
# ----------------------------------------------------------------------------
@dataclass
class Results:
    variants: list[Variant]
    timing: dict[str, Timing]
    throughput: dict[str, float]
    errors: dict[str, dict[str, ForceError]]
    estimators: list[EstimatorCase]
    peaks: dict[str, float]
    error_rate: float
    cycles: int
    block: int
    n_states: int
    batch_samples: int
    batch_repeats: int
    extras: dict[str, str]          # extra timed case key -> description
    max_abs_batch_vs_single: float
    wall_s: float = 0.0


def _fmt_n(x: float) -> str:
    if x == 0.0:
        return '0'
    if abs(x) >= 100:
        return f'{x:.0f}'
    if abs(x) >= 1:
        return f'{x:.1f}'
    if abs(x) >= 0.01:
        return f'{x:.3f}'
    return f'{x:.1e}'


def _fmt_pct(x: float) -> str:
    if x == 0.0:
        return '0 %'
    if abs(x) >= 10:
        return f'{x:.0f} %'
    if abs(x) >= 0.1:
        return f'{x:.1f} %'
    return '< 0.1 %'


def _fmt_err(e: ForceError) -> str:
    return f'{_fmt_n(e.max)} N ({_fmt_pct(e.max_pct)})'


def _fmt_delta(delta: float, p_value: float) -> str:
    text = f'{delta:+.1f}'
    return text if p_value < SIGNIFICANCE else f'{text} (noise)'


def _kind_label(v: Variant) -> str:
    return {REFERENCE: 'reference', SCENE: 'scene', DROPS: 'drops an effect',
            ADDS: 'adds to full'}[v.kind]


def _table(header: Sequence[str], rows: Sequence[Sequence[str]],
           align: Sequence[str] | None = None) -> str:
    align = align or ['l'] + ['r'] * (len(header) - 1)
    sep = ['---:' if a == 'r' else ':---' for a in align]
    lines = ['| ' + ' | '.join(header) + ' |', '| ' + ' | '.join(sep) + ' |']
    lines += ['| ' + ' | '.join(r) + ' |' for r in rows]
    return '\n'.join(lines)


def _time_cells(res: Results, key: str) -> list[str]:
    t = res.timing[key]
    delta = '0' if key == 'full' else _fmt_delta(*t.paired_delta_us(res.timing['full']))
    return [f'{t.median_us:.1f}', f'{t.p99_us:.0f}', f'{t.block_p99_us:.0f}', delta,
            f'{res.throughput[key] / 1e3:.0f}']


TIME_HEADER = ['median (us)', 'p99 (us)', 'p99, typical block (us)', 'vs full (us)',
               'batch (k samples/s)']


def main_table(res: Results) -> str:
    """Reference, scenes and the variants that drop an effect: time and max error."""
    header = ['variant', 'kind'] + TIME_HEADER + [f'max err {m}' for m in MOTIONS]
    rows = [[f'`{v.key}`', _kind_label(v)] + _time_cells(res, v.key)
            + [_fmt_err(res.errors[v.key][m]) for m in MOTIONS]
            for v in res.variants if v.kind != ADDS]
    return _table(header, rows, ['l', 'l'] + ['r'] * (len(header) - 2))


def additions_table(res: Results) -> str:
    """The variants that add a body or an effect to ``full``: time and what they add."""
    header = ['variant', 'adds to full'] + TIME_HEADER + [f'{m}: max / RMS diff (N)'
                                                         for m in MOTIONS]
    rows = [[f'`{v.key}`', v.description] + _time_cells(res, v.key)
            + [f'{_fmt_n(res.errors[v.key][m].max)} / {_fmt_n(res.errors[v.key][m].rms)}'
               for m in MOTIONS]
            for v in res.variants if v.kind == ADDS]
    return _table(header, rows, ['l', 'l'] + ['r'] * (len(header) - 2))


def rms_table(res: Results) -> str:
    header = ['variant'] + [f'{m}: max / RMS (N)' for m in MOTIONS]
    rows = []
    for v in res.variants:
        if v.kind == ADDS:
            continue
        cells = []
        for m in MOTIONS:
            e = res.errors[v.key][m]
            cells.append(f'{_fmt_n(e.max)} / {_fmt_n(e.rms)} ({_fmt_pct(e.max_pct)} / '
                         f'{_fmt_pct(e.rms_pct)})')
        rows.append([f'`{v.key}`'] + cells)
    return _table(header, rows)


def extras_table(res: Results) -> str:
    ref = res.timing['full']
    header = ['case', 'what it is', 'median (us)', 'p99 (us)', 'p99, typical block (us)',
              'time added to a full solve (us)', 'force error']
    rows = []
    for key, desc in res.extras.items():
        t = res.timing[key]
        if key.startswith('estimator'):
            added, err = f'+{t.median_us:.1f} (its own median)', 'see the estimator table'
        else:
            added = _fmt_delta(*t.paired_delta_us(ref))
            err = ('none (diagnostic only)' if key.startswith('full + cond')
                   else f'none (max diff {res.max_abs_batch_vs_single:.0e} N)')
        rows.append([f'`{key}`', desc, f'{t.median_us:.1f}', f'{t.p99_us:.0f}',
                     f'{t.block_p99_us:.0f}', added, err])
    return _table(header, rows, ['l', 'l', 'r', 'r', 'r', 'r', 'l'])


def estimator_table(res: Results) -> str:
    header = ['node receives', 'estimator', 'rate (Hz)']
    for m in ESTIMATOR_MOTIONS:
        header += [f'{m}: max', f'{m}: RMS', f'{m}: start-up max']
    rows = []
    for c in res.estimators:
        src = 'pose + twist' if c.source == 'twist' else 'pose only'
        row = [src, c.method, f'{c.rate:.0f}']
        for m in ESTIMATOR_MOTIONS:
            e = c.steady[m]
            row += [_fmt_err(e), f'{_fmt_n(e.rms)} N ({_fmt_pct(e.rms_pct)})',
                    f'{_fmt_n(c.startup_max[m])} N']
        rows.append(row)
    return _table(header, rows, ['l', 'l'] + ['r'] * (len(header) - 2))


def find_estimator(cases: Sequence[EstimatorCase], source: str, method: str,
                   rate: float) -> EstimatorCase:
    """The case of ``cases`` with this source ('twist' or 'pose'), method and rate."""
    return next(c for c in cases if c.source == source and c.method == method and c.rate == rate)


def summary(res: Results) -> list[str]:
    """Plain-language sentences for README, from the numbers."""
    ref = res.timing['full']
    by_key = {v.key: v for v in res.variants}
    out = []

    def saving(key: str) -> float | None:
        """us saved per cycle against full, None when within the noise."""
        delta, p_value = res.timing[key].paired_delta_us(ref)
        if p_value >= SIGNIFICANCE or abs(delta) < 0.01 * ref.median_us:
            return None
        return -delta

    def saves(key: str) -> str:
        us = saving(key)
        if us is None:
            return 'saves no measurable time'
        if us > 0:
            return f'saves {_us(us)} us per cycle ({100.0 * us / ref.median_us:.0f} %)'
        return f'costs {_us(-us)} us more per cycle'

    def err(key: str, motion: str, of_peak: str = ' of the peak force') -> str:
        e = res.errors[key][motion]
        return f'{_fmt_n(e.max)} N ({_fmt_pct(e.max_pct)}{of_peak})'

    def effect(key: str) -> str:
        return key.split(' - ', 1)[1].replace('_', ' ')

    out.append(f'On this machine one control cycle of the full model (`fsd.solve`) takes a '
               f'median of {_us(ref.median_us)} us (p99 of a typical stretch of cycles '
               f'{_us(ref.block_p99_us)} us); the peak actuator force is '
               f'{res.peaks["general"]:.0f} N on the paper\'s general motion and '
               f'{res.peaks["violent"]:.0f} N on the violent motion-cueing test motion.')
    if 'full - leg_inertia' in by_key:
        out.append(f'Dropping leg inertia {saves("full - leg_inertia")} and costs up to '
                   f'{err("full - leg_inertia", "general")} on the general motion and '
                   f'{err("full - leg_inertia", "violent", "")} on the violent one.')
    if 'quasi_static' in by_key:
        worst_slow = max(res.errors[v.key][m].max for v in res.variants
                         if v.kind in (SCENE, DROPS) and v.key != 'full - gravity'
                         for m in PAPER_EXAMPLES)
        out.append(f'The paper\'s motions are so slow that every variant without some '
                   f'inertia or velocity products stays within {_fmt_n(worst_slow)} N of the '
                   f'full model on them, but on the violent motion the gravity-only '
                   f'`quasi_static` scene, which {saves("quasi_static")}, is off by up to '
                   f'{err("quasi_static", "violent", "")}.')
    others = [v.key for v in res.variants if v.kind == DROPS and v.key != 'full - leg_inertia']
    measurable = sorted((k for k in others if (saving(k) or 0.0) > 0),
                        key=lambda k: -saving(k))
    idle = [k for k in others if k not in measurable]
    parts = [f'dropping {effect(k)} saves {_us(saving(k))} us and costs up to '
             f'{_fmt_n(res.errors[k]["violent"].max)} N' for k in measurable]
    text = ('On the violent motion, ' + ', '.join(parts)) if parts else ''
    if idle:
        items = [f'{effect(k)} (error up to {_fmt_n(res.errors[k]["violent"].max)} N)'
                 for k in idle]
        listed = items[0] if len(items) == 1 else ', '.join(items[:-1]) + ' or ' + items[-1]
        text += ('; ' if text else '') + f'dropping {listed} saves no measurable time'
    if text:
        out.append(text[0].upper() + text[1:] + '.')
    if 'payload' in by_key:
        us = saving('payload')
        cost = (f'costs {_us(-us)} us more per cycle' if us is not None and us < 0
                else 'costs no measurable time')
        payload = by_key['payload'].model.payload
        mass = f'{payload.mass:.0f} kg ' if payload is not None else ''
        out.append(f'Simulating the {mass}cab and occupant (`payload` scene) {cost} and '
                   f'changes the forces by up to {_fmt_n(res.errors["payload"]["violent"].max)} '
                   f'N on the violent motion (its own effect, not an error).')
    tw = {r: find_estimator(res.estimators, 'twist', 'backward2', r) for r in ESTIMATOR_RATES}
    po = {r: find_estimator(res.estimators, 'pose', 'backward2', r) for r in ESTIMATOR_RATES}

    def v(case: EstimatorCase) -> str:
        return _fmt_n(case.steady['violent'].max)
    out.append(f'Without an acceleration stream, the node\'s default estimator (backward2, '
               f'from the twists, about '
               f'{_us(res.timing["estimator backward2, pose + twist"].median_us)} us per cycle) '
               f'is off by up to {v(tw[60.0])} N at 60 Hz, {v(tw[250.0])} N at 250 Hz and '
               f'{v(tw[1000.0])} N at 1 kHz on the violent motion (from poses alone '
               f'{v(po[60.0])}, {v(po[250.0])} and {v(po[1000.0])} N), and by a negligible '
               f'{_fmt_n(max(c.steady["general"].max for c in tw.values()))} N on the '
               f'general motion once its first samples are past.')
    cond_delta, _ = res.timing['full + cond(Q)'].paired_delta_us(ref)
    out.append(f'The costliest option changes no force at all: the exact condition number '
               f'`sol.cond` (an SVD) adds {cond_delta:.0f} us per cycle, '
               f'{100.0 * cond_delta / ref.median_us:.0f} % of a solve, so it belongs in a '
               f'diagnostics report, not in every cycle; offline, `solve_batch` needs only '
               f'{1e6 / res.throughput["full"]:.1f} us per sample.')
    return out


def _load_average() -> str:
    try:
        return ' '.join(f'{x:.2f}' for x in os.getloadavg())
    except (AttributeError, OSError):
        return '?'


def command_line(args: argparse.Namespace) -> list[str]:
    """The options of this run that differ from the defaults (as typed)."""
    defaults = build_parser().parse_args([])
    out = []
    if args.quick:
        return ['--quick'] + (['--out-dir', args.out_dir] if args.out_dir != defaults.out_dir
                              else []) + (['--no-plot'] if args.no_plot else [])
    for name in ('cycles', 'block', 'warmup', 'batch_repeats', 'error_rate', 'out_dir'):
        value = getattr(args, name)
        if value != getattr(defaults, name):
            out += ['--' + name.replace('_', '-'), f'{value:g}' if isinstance(value, float)
                    else str(value)]
    if args.no_plot:
        out.append('--no-plot')
    return out


def cpu_model() -> str:
    """The processor's model name from /proc/cpuinfo ('' where there is none)."""
    try:
        with open('/proc/cpuinfo') as f:
            for line in f:
                if line.lower().startswith('model name'):
                    return line.split(':', 1)[1].strip()
    except OSError:
        pass
    return ''


def machine_header(argv: Sequence[str]) -> list[str]:
    cpu, usable = cpu_model(), kernel.usable_cores()
    env = ' '.join(f'{k}={os.environ[k]}' for k in ('OMP_NUM_THREADS', 'OPENBLAS_NUM_THREADS')
                   if k in os.environ)
    command = 'flight-sim-dynamics bench' + (' ' + shlex.join(argv) if argv else '')
    load = _load_average()
    return [
        f'- date: {datetime.datetime.now(datetime.timezone.utc):%Y-%m-%d %H:%M UTC}',
        f'- command: `{(env + " ") if env else ""}{command}`',
        f'- processor: `{platform.processor() or "(empty)"}` ({platform.machine()}), CPU model: '
        f'{cpu or "?"}, {os.cpu_count()} logical cores ({usable} usable by this process)',
        f'- Python {platform.python_version()} ({platform.python_implementation()}), '
        f'numpy {np.__version__}, {platform.system()} {platform.release()}',
        f'- load average at start (1, 5, 15 min): {load}',
    ]


def markdown(res: Results, header_lines: list[str], load_end: str) -> str:
    full = res.timing['full']
    buf = io.StringIO()
    w = buf.write
    w('# What accuracy costs in time: scenes and effects\n\n')
    w('## Summary\n\n')
    w(' '.join(summary(res)) + '\n\n')
    w('## Machine and command\n\n')
    w('\n'.join(header_lines) + '\n')
    w(f'- load average at end: {load_end}; whole run {res.wall_s:.0f} s\n\n')
    w('The machine is shared and noisy: other processes run beside the benchmark and '
      'preempt it now and then, so the overall p99 mostly measures them (one burst of '
      'load in one block is enough to move it); "p99, typical block" is the median over '
      'the blocks of each block\'s own p99, the tail of a typical stretch of cycles. '
      'Differences of a few us are noise: "vs full" is marked "(noise)" when a sign test '
      'over the interleaved blocks (is the variant faster than `full` in more blocks than '
      f'chance allows?) gives p >= {SIGNIFICANCE:g}. Differences between whole runs '
      'are larger than within one run (the load of the other processes changes): treat a '
      'difference under about 10 % of a solve as approximate. Compare the medians.\n\n')
    w('![time per cycle against maximum force error on the violent motion](scenes.png)\n\n')
    w('The figure: x = median time of one `fsd.solve` (for the estimator points: that of '
      '`full` plus the median of one `DerivativeEstimator.update`); y = maximum force '
      'error against `full` on the violent motion, log scale; exact variants (0 N) sit '
      'on the dotted floor. For `payload` and `full + friction` y is the size of what '
      'they add, not an error.\n\n')

    w('## Time per cycle and force error\n\n')
    w(f'Time: `fsd.solve(model, q, qd, qdd)` called {res.cycles} times per variant, in this '
      f'process, with plain-float states cycled through the {res.n_states} samples of the '
      f'four motions below (100 Hz); each call timed alone with `time.perf_counter_ns`; '
      f'after a warm-up, the variants interleaved call by call (for each state one call '
      f'of every variant, in an order shuffled anew for each state). "vs full" is '
      f'the median over blocks of {res.block} states of (block median of the variant - '
      f'block median of `full`); negative = faster. Since every call follows calls of '
      f'other variants, the caches are about as warm as in a node that does other work '
      f'between cycles (a small call such as `DerivativeEstimator.update` takes a few '
      f'times longer here than in a tight loop of its own). "batch" is '
      f'`fsd.solve_batch` on all {res.batch_samples} samples of the four motions at '
      f'{res.error_rate:.0f} Hz (best of {res.batch_repeats} calls).\n\n')
    w(f'Force error: max over the samples ({res.error_rate:.0f} Hz) and the three legs of '
      f'|f_variant - f_full|, in N and in % of the full model\'s peak |f| on that motion ('
      + ', '.join(f'{m}: {res.peaks[m]:.1f} N' for m in MOTIONS) + ').\n\n')
    w(main_table(res) + '\n\n')
    w('### Max and RMS force error per motion\n\n')
    w('Each cell: max / RMS in N (max / RMS in % of the peak force).\n\n')
    w(rms_table(res) + '\n\n')
    w('### Variants that add to the full model\n\n')
    w('`payload` (the packaged scene: a cab and occupant on the platform, an extra rigid '
      'body) and `full + friction` (actuator friction, `friction.*` parameters) simulate '
      '*more* than `full`: the difference to `full` is the size of what they add, not an '
      'error of either model.\n\n')
    w(additions_table(res) + '\n\n')

    w('## Missing accelerations: the node\'s estimator\n\n')
    w('When the planner sends no acceleration (or no twist either), the node estimates '
      'them with `setpoints.DerivativeEstimator` (parameter `estimator.method`: '
      '`backward` = two-point differences, `backward2` = BDF2, the default). Here the '
      'samples of the exact motion at 60, 250 and 1000 Hz are fed to it in order, either '
      'pose + exact twist ("pose + twist": only the accelerations are estimated, from '
      'successive twists) or pose only (rates from poses, accelerations from those '
      'rates); the full model is solved with what the estimator returns and compared '
      'with the full model on the exact rates and accelerations at the same samples. '
      f'"max" and "RMS" are over the samples from the {STARTUP_SAMPLES + 1}th on; the '
      f'first {STARTUP_SAMPLES}, while the history fills (the first acceleration is '
      'taken as zero: the estimator assumes a start from rest), are in "start-up max". '
      'The paper\'s motions start with a nonzero acceleration (hence their start-up '
      'error); the violent one starts from rest. % are of the same peak forces as '
      'above.\n\n')
    w(estimator_table(res) + '\n\n')

    w('## Other speed/accuracy trades\n\n')
    w('Timed in the same interleaved run as the variants (same states, same number of '
      'calls):\n\n')
    w(extras_table(res) + '\n\n')
    w(f'`solve_batch` gives the same forces as `solve` (max difference '
      f'{res.max_abs_batch_vs_single:.0e} N over the test samples) at '
      f'{res.throughput["full"] / 1e3:.0f} k samples/s for the full model, i.e. '
      f'{1e6 / res.throughput["full"]:.1f} us per sample against '
      f'{full.median_us:.0f} us for one `solve`: worth it offline (the `solve` '
      f'subcommand uses it), useless per cycle, since a batch of one costs more than '
      f'`solve`. The estimator rows are the cost of `DerivativeEstimator.update` '
      f'alone, paid on top of the solve when the node estimates.\n\n')

    w('## The violent motion\n\n')
    q, qd, qdd = violent_motion(sample_times(VIOLENT_DURATION, 1000.0))
    w('A motion-cueing-like sequence compressed into short, overlapping onset cues '
      'and washouts (`flight_sim_dynamics.bench.VIOLENT_STEPS`): each row is a quintic '
      'smooth step `s(u) = 10u^3 - 15u^4 + 6u^5`, `u = (t - start) / duration`, of the '
      'coordinate by `change` (the steps of one coordinate add up), so position, rate '
      'and acceleration are continuous and exact; it starts and ends at rest in the '
      f'central configuration and lasts {VIOLENT_DURATION:g} s. Peak |acceleration|: '
      f'surge {np.abs(qdd[:, 0]).max():.1f} m/s^2, heave {np.abs(qdd[:, 1]).max():.1f} '
      f'm/s^2 (up to {np.abs(qdd[:, :2]).max() / 9.80665:.2f} g), roll '
      f'{np.abs(qdd[:, 2]).max():.1f} rad/s^2; range: surge '
      f'{q[:, 0].min():+.2f}..{q[:, 0].max():+.2f} m, heave {q[:, 1].min():+.2f}..'
      f'{q[:, 1].max():+.2f} m, roll {q[:, 2].min():+.2f}..{q[:, 2].max():+.2f} rad; peak '
      f'rates {np.abs(qd[:, 0]).max():.2f} m/s, {np.abs(qd[:, 1]).max():.2f} m/s, '
      f'{np.abs(qd[:, 2]).max():.2f} rad/s.\n\n')
    sol = fsd.solve_batch(res.variants[0].model, q, qd, qdd)
    w(f'Its actuator speeds reach {np.abs(sol.rate).max():.2f} m/s and strokes '
      f'{sol.stroke.min():+.2f}..{sol.stroke.max():+.2f} m: a deliberately harsh test of '
      f'the model, not a motion to run on the machine.\n\n')
    rows = [[['surge', 'heave', 'roll'][a], f'{s:.2f}', f'{d:.2f}',
             f'{c:+.2f} {"rad" if a == 2 else "m"}',
             f'{5.7735 * abs(c) / d ** 2:.1f} {"rad/s^2" if a == 2 else "m/s^2"}']
            for a, s, d, c in VIOLENT_STEPS]
    w(_table(['coordinate', 'start (s)', 'duration (s)', 'change', 'peak acc. of the step'],
             rows, ['l', 'r', 'r', 'r', 'r']) + '\n\n')
    w_ = math.pi / PAPER_DURATION
    lin = max(max(a[0], a[1]) for a in PAPER_EXAMPLES.values()) * w_ ** 2
    ang = max(a[2] for a in PAPER_EXAMPLES.values()) * w_ ** 2
    w('The paper\'s motions (eq. 6, `vertical`, `rectilinear`, `general`) are '
      f'`x*(1 - cos(pi t / {PAPER_DURATION:g}))`: peak accelerations of {lin:.2f} m/s^2 '
      f'and {ang:.2f} rad/s^2, i.e. nearly quasi-static.\n')
    return buf.getvalue()


def plot(res: Results, path: str) -> None:
    """Time per cycle (x) against max force error on the violent motion (log y)."""
    from matplotlib.figure import Figure
    from matplotlib.ticker import FuncFormatter, LogFormatterSciNotation

    from .csv_io import atomic_output

    errors = {v.key: res.errors[v.key]['violent'].max for v in res.variants}
    positive = [e for e in errors.values() if e > 0]
    est_points = []
    full_us = res.timing['full'].median_us
    for c in res.estimators:
        if c.method == 'backward2':
            key = f'estimator backward2, {"pose + twist" if c.source == "twist" else "pose only"}'
            x = full_us + res.timing[key].median_us
            est_points.append((x, c.steady['violent'].max,
                               f'{"qdd" if c.source == "twist" else "qd, qdd"} est. '
                               f'{c.rate:.0f} Hz', c.source))
    positive += [p[1] for p in est_points if p[1] > 0]
    floor = 10 ** (math.floor(math.log10(min(positive))) - 1) if positive else 1e-3
    fig = Figure(figsize=(10.0, 6.5), dpi=110, layout='constrained')
    ax = fig.subplots()
    styles = {REFERENCE: dict(marker='*', s=180, color='black'),
              SCENE: dict(marker='o', s=70, color='tab:blue'),
              DROPS: dict(marker='v', s=70, color='tab:red'),
              ADDS: dict(marker='s', s=60, facecolors='none', edgecolors='tab:green',
                         linewidths=1.5)}
    seen = set()
    labels = []      # (x, y, text, colour, font size), placed at the end
    for v in res.variants:
        x = res.timing[v.key].median_us
        y = errors[v.key] if errors[v.key] > 0 else floor
        label = {REFERENCE: 'full (reference)', SCENE: 'packaged scene',
                 DROPS: 'full without one effect',
                 ADDS: 'adds a body/effect (difference = its size)'}[v.kind]
        ax.scatter([x], [y], zorder=3, label=None if v.kind in seen else label,
                   **styles[v.kind])
        seen.add(v.kind)
        labels.append((x, y, v.key + (' (exact)' if errors[v.key] == 0 else ''), 'black', 8.5))
    cond = res.timing['full + cond(Q)'].median_us
    ax.scatter([cond], [floor], marker='X', s=70, color='tab:purple', zorder=3,
               label='full + cond(Q) diagnostic (exact)')
    labels.append((cond, floor, 'full + cond(Q) (exact)', 'black', 8.5))
    first = {}
    for x, y, text, source in est_points:
        color = 'tab:orange' if source == 'twist' else 'tab:brown'
        lab = ('full, accelerations estimated from twists (backward2)' if source == 'twist'
               else 'full, rates and accelerations from poses (backward2)')
        ax.scatter([x], [max(y, floor)], marker='D', s=40, color=color, zorder=3,
                   label=None if source in first else lab)
        first[source] = True
        labels.append((x, max(y, floor), text, color, 7.5))
    ax.set_yscale('log')
    ax.axhline(floor, color='0.6', linewidth=0.8, linestyle=':')
    log_format = LogFormatterSciNotation()
    ax.yaxis.set_major_formatter(FuncFormatter(
        lambda y, pos: 'exact (0 N)' if abs(y - floor) <= 1e-9 * floor else log_format(y, pos)))
    y_lo, y_hi = ax.get_ylim()
    ax.set_yticks(sorted(set(ax.get_yticks()) | {floor}))
    ax.set_ylim(y_lo, y_hi)
    ax.set_xlabel('median time per cycle, fsd.solve (us)')
    ax.set_ylabel('max |force error| vs full model, violent motion (N)')
    ax.set_title('What accuracy costs in time: one point per variant '
                 f'(peak force {res.peaks["violent"]:.0f} N)', fontsize='medium')
    ax.grid(True, which='both', alpha=0.3)
    xs = [res.timing[v.key].median_us for v in res.variants] + [cond] + \
        [p[0] for p in est_points]
    lo, hi = min(xs), max(xs)
    ax.set_xlim(lo - 0.05 * (hi - lo) - 1, hi + 0.25 * (hi - lo) + 1)
    ax.legend(loc='upper right', fontsize=8)
    _place_labels(fig, ax, labels)
    with atomic_output(path) as f:
        fig.savefig(f, format='png')


def _place_labels(fig, ax, labels) -> None:
    """Annotate the points, each label at the first of a few offsets where it
    overlaps neither an earlier label nor a point nor the legend."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    renderer = FigureCanvasAgg(fig).get_renderer()
    fig.draw(renderer)                     # final layout, so the extents are right
    markers, placed = [], []
    for x, y, *_ in labels:                # the markers themselves
        px, py = ax.transData.transform((x, y))
        markers.append((px - 7, py - 7, px + 7, py + 7))
    legend = ax.get_legend()
    if legend is not None:
        bb = legend.get_window_extent(renderer)
        markers.append((bb.x0, bb.y0, bb.x1, bb.y1))
    axes_bb = ax.get_window_extent(renderer)
    offsets = [(7, 3, 'left'), (7, -11, 'left'), (-7, 3, 'right'), (-7, -11, 'right'),
               (7, 12, 'left'), (7, -20, 'left'), (-7, 12, 'right'), (-7, -20, 'right'),
               (0, 10, 'center'), (0, -18, 'center')]
    offsets += [(dx, dy, ha) for dx, ha in ((12, 'left'), (-12, 'right'), (30, 'left'),
                                            (-30, 'right'))
                for dy in (-4, 8, -16, 20, -28)]

    def overlap(bb, boxes, pad: float) -> float:
        area = 0.0
        for t in boxes:
            w = min(bb.x1 + pad, t[2]) - max(bb.x0 - pad, t[0])
            h = min(bb.y1 + pad, t[3]) - max(bb.y0 - pad, t[1])
            if w > 0 and h > 0:
                area += w * h
        return area

    def badness(bb) -> float:
        outside = (max(0.0, axes_bb.x0 - bb.x0) + max(0.0, bb.x1 - axes_bb.x1)
                   + max(0.0, axes_bb.y0 - bb.y0) + max(0.0, bb.y1 - axes_bb.y1))
        return 1e3 * outside + overlap(bb, markers, 0.0) + overlap(bb, placed, 3.0)

    for x, y, text, colour, size in labels:
        best = None
        for dx, dy, ha in offsets:
            ann = ax.annotate(text, (x, y), textcoords='offset points', xytext=(dx, dy),
                              fontsize=size, color=colour, ha=ha)
            bb = ann.get_window_extent(renderer)
            score = badness(bb)
            if best is None or score < best[0]:
                if best is not None:
                    best[1].remove()
                best = (score, ann, bb)
            else:
                ann.remove()
            if score == 0.0:
                break
        score, ann, bb = best
        if abs(ann.xyann[0]) > 10 or abs(ann.xyann[1]) > 14:     # far off: show whose it is
            ann.remove()
            ann = ax.annotate(text, (x, y), textcoords='offset points', xytext=ann.xyann,
                              fontsize=size, color=colour, ha=ann.get_ha(),
                              arrowprops=dict(arrowstyle='-', color=colour, alpha=0.5,
                                              linewidth=0.6, shrinkA=0, shrinkB=4))
        placed.append((bb.x0, bb.y0, bb.x1, bb.y1))
    fig.set_layout_engine('none')          # keep the layout the labels were placed in


def _write_text(path: str, text: str) -> None:
    from .csv_io import atomic_output

    with atomic_output(path) as f:
        f.write(text.encode())


# ----------------------------------------------------------------------------
# Command line
# ----------------------------------------------------------------------------
def configure(p: argparse.ArgumentParser) -> None:
    p.add_argument('--cycles', type=int, default=10_000, metavar='N',
                   help='timed fsd.solve calls per variant (default 10000)')
    p.add_argument('--block', type=int, default=250, metavar='N',
                   help='calls per interleaved timing block (default 250)')
    p.add_argument('--warmup', type=int, default=300, metavar='N',
                   help='untimed calls per variant first (default 300)')
    p.add_argument('--batch-repeats', type=int, default=15, metavar='N',
                   help='solve_batch calls per variant for the throughput (best of; '
                        'default 15)')
    p.add_argument('--error-rate', type=float, default=1000.0, metavar='HZ',
                   help='sampling rate of the motions for the force errors (default 1000)')
    p.add_argument('--quick', action='store_true',
                   help='a fast smoke run (200 cycles, blocks of 50, 200 Hz errors, '
                        '2 batch repeats): numbers only roughly meaningful')
    p.add_argument('--out-dir', default='docs', metavar='DIR',
                   help='where scenes.md and scenes.png go (default docs)')
    p.add_argument('--no-plot', action='store_true', help='do not write scenes.png')


def run(args: argparse.Namespace) -> int:
    """Run the benchmark (the ``bench`` subcommand's handler); returns 0."""
    t_start = time.perf_counter()
    header = machine_header(command_line(args))
    if args.quick:
        args.cycles, args.block, args.warmup = 200, 50, 20
        args.error_rate, args.batch_repeats = 200.0, 2
    for name in ('cycles', 'block', 'batch_repeats'):
        if getattr(args, name) < 1:
            raise ValueError(f'--{name.replace("_", "-")} must be at least 1')
    if args.warmup < 0 or not (math.isfinite(args.error_rate) and args.error_rate >= 10.0):
        raise ValueError('--warmup must be >= 0 and --error-rate >= 10 Hz')
    os.makedirs(args.out_dir, exist_ok=True)

    def progress(msg: str) -> None:
        print(f'[bench] {msg}', file=sys.stderr, flush=True)

    vs = variants()
    full = vs[0].model
    ms = motion_set(full, args.error_rate)
    progress('force errors of the variants')
    errors = {v.key: variant_errors(v, ms) for v in vs}
    progress('estimator errors')
    est = estimator_cases(full, ms.peak)

    # States for the per-cycle timing: the four motions at 100 Hz, plain floats.
    states = []
    for name in MOTIONS:
        q, qd, qdd = motion(name, sample_times(motion_duration(name), 100.0))
        states += [(tuple(a.tolist()), tuple(b.tolist()), tuple(c.tolist()))
                   for a, b, c in zip(q, qd, qdd)]
    batch1 = [tuple(np.array([s], dtype=float) for s in state) for state in states]
    cases = {v.key: Case(partial(fsd.solve, v.model), states) for v in vs}
    extras = {
        'full + cond(Q)': 'full solve and reading `sol.cond`, the exact 2-norm condition '
                          'number of Q (an SVD, computed on first access only)',
        'solve_batch, N = 1': '`fsd.solve_batch(full, ...)` on a batch of one sample',
    }
    cases['full + cond(Q)'] = Case(partial(_solve_cond, full), states)
    cases['solve_batch, N = 1'] = Case(partial(fsd.solve_batch, full), batch1)
    for method in ESTIMATORS:
        for twist in (True, False):
            key = f'estimator {method}, {"pose + twist" if twist else "pose only"}'
            extras[key] = (f'`DerivativeEstimator("{method}").update` alone (250 Hz stamps), '
                           + ('accelerations from exact twists' if twist
                              else 'rates and accelerations from poses'))
            cases[key] = Case(_EstimatorCall(method, 250.0, twist), states)
    progress(f'timing {len(cases)} cases x {args.cycles} cycles')
    timing = time_cases(cases, args.cycles, args.block, args.warmup, progress)

    progress('solve_batch throughput')
    Q = np.concatenate([ms.q[m] for m in MOTIONS])
    Qd = np.concatenate([ms.qd[m] for m in MOTIONS])
    Qdd = np.concatenate([ms.qdd[m] for m in MOTIONS])
    throughput = batch_throughput({v.key: v.model for v in vs}, Q, Qd, Qdd, args.batch_repeats)
    single = np.array([fsd.solve(full, *s).force for s in states])
    arrays = [np.array([s[i] for s in states]) for i in range(3)]
    max_diff = float(np.abs(fsd.solve_batch(full, *arrays).force - single).max())

    res = Results(variants=vs, timing=timing, throughput=throughput, errors=errors,
                  estimators=est, peaks=ms.peak, error_rate=args.error_rate,
                  cycles=args.cycles, block=args.block, n_states=len(states),
                  batch_samples=len(Q), batch_repeats=args.batch_repeats, extras=extras,
                  max_abs_batch_vs_single=max_diff)
    res.wall_s = time.perf_counter() - t_start
    text = markdown(res, header, _load_average())
    md_path = os.path.join(args.out_dir, 'scenes.md')
    _write_text(md_path, text)
    if not args.no_plot:
        plot(res, os.path.join(args.out_dir, 'scenes.png'))
    print('## Summary\n\n' + '\n'.join(summary(res)) + '\n')
    print(main_table(res) + '\n')
    print(rms_table(res) + '\n')
    print(additions_table(res) + '\n')
    print(estimator_table(res) + '\n')
    print(extras_table(res))
    progress(f'wrote {md_path}' + ('' if args.no_plot else
                                   f' and {os.path.join(args.out_dir, "scenes.png")}')
             + f' in {time.perf_counter() - t_start:.0f} s')
    return 0


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog='flight-sim-dynamics bench',
        description='Measure solve time per cycle against force error for every scene and '
                    'single-effect variant, and the cost of estimating missing '
                    'accelerations; writes scenes.md and scenes.png.')
    configure(p)
    return p


def main(argv: Sequence[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    args = build_parser().parse_args(argv)
    return run(args)


if __name__ == '__main__':
    sys.exit(main())
