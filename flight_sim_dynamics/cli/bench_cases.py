"""The measurements of ``flight-sim-dynamics bench``: variants, force errors,
the estimator study and interleaved timing (no report, no plot).

* the variants: every packaged scene, ``full`` without one of its effects,
  ``full`` with friction (:func:`variants`);
* force errors against ``full`` on the test motions (the paper's three, eq. 6,
  and ``violent``: :data:`flight_sim_dynamics.core.motions.TEST_MOTIONS`);
* the cost of missing accelerations (and twists): the node's
  :class:`~flight_sim_dynamics.core.estimator.DerivativeEstimator` fed the
  exact samples (:func:`estimator_cases`; ``python -m benchmarks.estimation``
  runs the same study on other motions and rates);
* timing: cases interleaved call by call in an order shuffled anew for each
  state, each call timed alone with ``time.perf_counter_ns``, statistics per
  block of states, paired against ``full`` with a sign test
  (:func:`time_cases`, :func:`sign_test`). No rclpy needed.
"""
from __future__ import annotations

import gc
import math
import random
import time
from dataclasses import dataclass, field, replace
from typing import Callable, Sequence

import numpy as np

import flight_sim_dynamics as fsd

from ..config.scenes import available_scenes, load_scene
from ..core.effects import EFFECT_NAMES
from ..core.model import Model
from ..core.motions import TEST_MOTIONS as MOTIONS
from ..core.motions import duration, motion, sample_times
from ..core.estimator import ESTIMATORS, DerivativeEstimator

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
    ``full`` with each effect it lacks that no packaged scene adds (friction
    today), described by its own ``<effect>.*`` parameters.
    """
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
    added = {e for name in available_scenes() for e in fsd.load_model(scene=name).effects.enabled()}
    for effect in EFFECT_NAMES:
        if getattr(full.effects, effect) or effect in added:
            continue
        own = ', '.join(f'{k} {_fmt_value(v)}' for k, v in full.values.items()
                        if k.startswith(effect + '.'))
        out.append(Variant(f'full + {effect}', ADDS,
                           full.with_effects(replace(full.effects, **{effect: True}),
                                             scene=f'full_with_{effect}'),
                           f'full model plus {effect}' + (f' ({own})' if own else '')))
    return out


def _fmt_value(value: object) -> str:
    """A parameter value for a description: ``0.5`` or ``[20, 20, 20]``."""
    if isinstance(value, (list, tuple)):
        return '[' + ', '.join(f'{float(x):g}' for x in value) + ']'
    return f'{float(value):g}' if isinstance(value, (int, float)) else str(value)


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
        q, qd, qdd = motion(name, sample_times(rate, duration(name)))
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
    """Force errors of the full model solved with the estimator's rates and
    accelerations against the exact ones, per motion.
    """

    source: str                 # 'twist' (exact qd given) or 'pose' (pose only)
    method: str
    rate: float
    steady: dict[str, ForceError]     # samples ``startup``.. on
    startup_max: dict[str, float]     # max |force error| over the first ``startup`` samples, N
    accel_max: dict[str, float] = field(default_factory=dict)   # steady max |qdd error|, SI


def estimate(method: str, rate: float, name: str, twist: bool
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Feed the node's estimator the samples of motion ``name`` at ``rate`` Hz
    (pose and exact twist, or pose only); returns q, the rates and
    accelerations the node would use, and the exact ones.
    """
    t = sample_times(rate, duration(name))
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
                    rates: Sequence[float] = ESTIMATOR_RATES,
                    motions: Sequence[str] = ESTIMATOR_MOTIONS,
                    startup: int = STARTUP_SAMPLES) -> list[EstimatorCase]:
    """Every source ('twist', 'pose') x estimator method x rate, on ``motions``;
    ``peaks``: the full model's peak |force| per motion (for the %).
    """
    out = []
    for source in ('twist', 'pose'):
        for method in ESTIMATORS:
            for rate in rates:
                steady, start, accel = {}, {}, {}
                for name in motions:
                    q, qd_used, qdd_used, qd, qdd = estimate(method, rate, name,
                                                             source == 'twist')
                    f_est = fsd.solve_batch(full, q, qd_used, qdd_used).force
                    f_ref = fsd.solve_batch(full, q, qd, qdd).force
                    k = startup
                    steady[name] = force_error(f_est[k:], f_ref[k:], peaks[name])
                    start[name] = float(np.abs(f_est[:k] - f_ref[:k]).max())
                    accel[name] = float(np.abs(qdd_used[k:] - qdd[k:]).max())
                out.append(EstimatorCase(source, method, rate, steady, start, accel))
    return out


def motion_peaks(full: Model, names: Sequence[str], rate: float) -> dict[str, float]:
    """Peak |force| of the full model on each motion sampled at ``rate`` Hz."""
    return {name: float(np.abs(fsd.solve_batch(full, *motion(
        name, sample_times(rate, duration(name)))).force).max()) for name in names}


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
        stretch of cycles, less swayed by a burst of load in one block.
        """
        return float(np.median(self.block_p99s)) / 1e3

    def paired_delta_us(self, other: 'Timing') -> tuple[float, float]:
        """(median over the blocks of (block median of self - that of ``other``
        in the same round), two-sided sign-test p-value of that difference).
        """
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
    other one), so a burst of load from other processes hits them all alike; the
    statistics are also kept per block of ``block`` states, whose
    medians pair the cases over the same stretch of time.
    """
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
    long (tens of ms), so its median would measure that load.
    """
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


class EstimatorCall:
    """One :meth:`DerivativeEstimator.update` per call, at a steady ``rate``."""

    def __init__(self, method: str, rate: float, twist: bool) -> None:
        self.est = DerivativeEstimator(method)
        self.dt = 1.0 / rate
        self.t = 0.0
        self.twist = twist

    def __call__(self, q, qd, qdd) -> None:
        self.t += self.dt
        self.est.update(self.t, q, qd if self.twist else None, None)


def solve_cond(model: Model, q, qd, qdd) -> float:
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



def find_estimator(cases: Sequence[EstimatorCase], source: str, method: str,
                   rate: float) -> EstimatorCase:
    """The case of ``cases`` with this source ('twist' or 'pose'), method and rate."""
    return next(c for c in cases if c.source == source and c.method == method and c.rate == rate)

