"""What each effect costs and buys: ``flight-sim-dynamics bench``. Per packaged
scene and single-effect variant of ``full`` (the effects the machine of
``--params`` models), the median and p99 time of a cycle against the force
error relative to ``full`` on the machine's bench motions (``Machine.
bench_motions``), and the error when the node's estimator supplies the
accelerations.
"""
from __future__ import annotations

import argparse
import math
import os
import platform
import random
import shlex
import sys
import time
from dataclasses import dataclass, replace
from typing import Callable, Sequence

import numpy as np

import flight_sim_dynamics as fsd

from ..config.scenes import available_scenes
from ..core.estimator import ESTIMATORS, estimate_rows
from ..core.machine import Machine
from ..machines import MACHINES
from ..machines.api import absent_effects
from .main import load_model

DOCS_DIR = 'docs'
DEFAULT_OUT_DIR = 'out'
ESTIMATOR_RATES = (60.0, 250.0, 1000.0)
#: Samples before the estimator's history is full; its error is reported after.
STARTUP_SAMPLES = 4
#: The estimator drawn on the figure (the node's default).
FIGURE_ESTIMATOR = 'backward2'


@dataclass(frozen=True)
class Variant:
    key: str
    kind: str          # 'reference', 'scene', 'drops' (full minus one effect), 'adds'
    model: object
    absent: str = ''   # adds only effects the model's parameters leave empty: why (absent_effects)


def _absent(full, model, absent: dict[str, str]) -> str:
    """Why ``model`` adds nothing to ``full``: every effect it adds is absent."""
    added = sorted(set(model.effects.enabled()) - set(full.effects.enabled()))
    return '; '.join(absent[e] for e in added) if added and set(added) <= set(absent) else ''


def variants(params: str | None = None) -> list[Variant]:
    """``full``, the other packaged scenes, ``full`` minus each of its effects,
    ``full`` plus each effect no scene adds (of the parameters ``params``; only
    the effects its machine models).
    """
    # every scene in turn: a payload the full scene leaves out is no news here
    full = load_model(params, scene='full', machines=MACHINES, show_notes=False)
    modelled = fsd.machine_of(full).effects
    absent = absent_effects(full)
    out = [Variant('full', 'reference', full)]
    added = set()
    for name in available_scenes():
        if name != 'full':
            model = load_model(params, scene=name, machines=MACHINES, show_notes=False)
            extra = set(model.effects.enabled()) - set(full.effects.enabled())
            added |= extra
            out.append(Variant(name, 'adds' if extra else 'scene', model,
                               _absent(full, model, absent)))
    for effect in full.effects.enabled():
        if effect not in modelled:
            continue
        out.append(Variant(f'full - {effect}', 'drops', full.with_effects(
            full.effects.without(effect), scene=f'full_without_{effect}')))
    for effect in modelled:
        if not getattr(full.effects, effect) and effect not in added:
            model = full.with_effects(replace(full.effects, **{effect: True}),
                                      scene=f'full_with_{effect}')
            out.append(Variant(f'full + {effect}', 'adds', model, _absent(full, model, absent)))
    return out


def exact_motions(rate: float, machine: Machine = MACHINES[0]
                  ) -> dict[str, tuple[np.ndarray, ...]]:
    """t, q, qd, qdd of every bench motion of ``machine`` sampled at ``rate`` Hz."""
    return {name: machine.motions[name].sampled(rate) for name in machine.bench_motions}


def force_errors(model, motions: dict, reference: dict[str, np.ndarray]
                 ) -> dict[str, float]:
    """Max |force - reference force| (N, over samples and legs) per motion."""
    return {name: float(np.abs(fsd.solve_batch(model, *m[1:]).force - reference[name]).max())
            for name, m in motions.items()}


def estimated(method: str, rate: float, name: str, twist: bool,
              machine: Machine = MACHINES[0]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The poses q, and the rates and accelerations the node's estimator gives for
    ``machine``'s motion ``name`` streamed at ``rate`` Hz (poses and exact
    twists, or poses only; its angles unwrapped).
    """
    t, q, qd, _ = machine.motions[name].sampled(rate)
    return (q, *estimate_rows(t, q, qd if twist else None, method, angles=machine.angles))


def estimator_errors(full, name: str | None = None) -> list[tuple[str, str, float, float]]:
    """(source, method, rate, max force error N after start-up) on the motion
    ``name`` (default: the machine's last bench motion, the most demanding).
    """
    machine = fsd.machine_of(full)
    name = machine.bench_motions[-1] if name is None else name
    out = []
    for source in ('pose + twist', 'pose only'):
        for method in ESTIMATORS:
            for rate in ESTIMATOR_RATES:
                q, qd, qdd = estimated(method, rate, name, source == 'pose + twist', machine)
                exact = fsd.solve_batch(full, *machine.motions[name].sampled(rate)[1:])
                f = fsd.solve_batch(full, q, qd, qdd).force
                k = STARTUP_SAMPLES
                out.append((source, method, rate, float(np.abs(f[k:] - exact.force[k:]).max())))
    return out


def time_per_cycle(models: dict[str, object], states: list, cycles: int
                   ) -> dict[str, tuple[float, float]]:
    """(median, p99) us of one ``fsd.solve`` per model, interleaved call by call."""
    calls: list[Callable] = [lambda s, m=m: fsd.solve(m, *s) for m in models.values()]
    for call in calls:
        for s in states[:100]:                                     # warm-up
            call(s)
    times = [[0] * cycles for _ in calls]
    order = list(range(len(calls)))
    rng = random.Random(1)
    clock = time.perf_counter_ns
    for k in range(cycles):
        s = states[k % len(states)]
        rng.shuffle(order)
        for i in order:
            t0 = clock()
            calls[i](s)
            times[i][k] = clock() - t0
    return {key: (float(np.median(t)) / 1e3, float(np.percentile(t, 99)) / 1e3)
            for key, t in zip(models, times)}


def table(columns: Sequence[str], rows: Sequence[Sequence[str]]) -> str:
    """A markdown table: the first column left-aligned, the others right."""
    return '\n'.join(['| ' + ' | '.join(columns) + ' |',
                      '| :--- |' + ' ---: |' * (len(columns) - 1)]
                     + ['| ' + ' | '.join(map(str, r)) + ' |' for r in rows])


def plot(points: list[tuple[str, str, float, float]], peak: float, path: str,
         name: str = 'violent') -> None:
    """One row per variant, most accurate first: max force error on the motion
    ``name`` (log axis, 'exact' for 0 N) and median time per cycle.
    """
    from matplotlib.figure import Figure

    points = sorted(points, key=lambda p: (p[2], p[0]))
    positive = [p[2] for p in points if p[2] > 0]
    floor = 10 ** (math.floor(math.log10(min(positive, default=1.0))) - 1)
    colour = {'reference': 'black', 'scene': 'tab:blue', 'drops': 'tab:red', 'adds': 'tab:green',
              'estimated': 'tab:orange', 'absent': '0.75'}
    fig = Figure(figsize=(11.0, 0.32 * len(points) + 1.8), dpi=110, layout='constrained')
    ax_e, ax_t = fig.subplots(1, 2, sharey=True, width_ratios=(3, 2))
    y = np.arange(len(points))
    colours = [colour[p[1]] for p in points]
    ax_e.barh(y, [max(p[2], floor) for p in points], left=floor / 10, color=colours)
    for k, p in enumerate(points):
        text = 'absent from the model' if p[1] == 'absent' else \
            'exact' if p[2] == 0 else f'{p[2]:.3g} N'
        ax_e.text(max(p[2], floor) * 1.15, k, text, va='center', fontsize=8)
        ax_t.text(p[3], k, f' {p[3]:.1f} us', va='center', fontsize=8)
    ax_e.set_xscale('log')
    ax_e.set_xlim(floor / 10, max(positive, default=1.0) * 20)
    ax_e.set_yticks(y, [p[0] for p in points], fontsize=8.5)
    ax_e.set_xlabel(f'max |force error| vs full on the {name} motion (N; peak {peak:.0f} N)')
    ax_t.barh(y, [p[3] for p in points], color=colours)
    ax_t.set_xlim(0, max(p[3] for p in points) * 1.3)
    ax_t.set_xlabel('median time per cycle, fsd.solve (us)')
    ax_e.invert_yaxis()
    fig.suptitle('What each effect costs and buys, most accurate first', fontsize='medium')
    fig.savefig(path, format='png')


@dataclass(frozen=True)
class Measured:
    """What ``bench`` measures on one machine (:func:`measure`)."""

    effects: str            # markdown table: time and force error per variant
    estimator: str          # markdown table: force error on estimated rates/accelerations
    peak: dict[str, float]  # peak |force| of full per bench motion, N
    focus: str              # the bench motion of the figure and the estimator (the last)
    points: list            # the figure's bars: (label, kind, error N, median us)
    kernel: bool            # whether the machine's compiled kernel ran


def measure(params: str | None, cycles: int, error_rate: float) -> Measured:
    """Time per cycle and force errors of every variant (module docstring)."""
    vs = variants(params)
    full = vs[0].model
    machine = fsd.machine_of(full)
    focus = machine.bench_motions[-1]
    motions = exact_motions(error_rate, machine)
    reference = {name: fsd.solve_batch(full, *m[1:]).force for name, m in motions.items()}
    peak = {name: float(np.abs(f).max()) for name, f in reference.items()}
    errors = {v.key: force_errors(v.model, motions, reference) for v in vs}
    states = [tuple(tuple(x) for x in row) for name in machine.bench_motions
              for row in zip(*(a.tolist() for a in machine.motions[name].sampled(100.0)[1:]))]
    timing = time_per_cycle({v.key: v.model for v in vs}, states, cycles)
    estimates = estimator_errors(full, focus)

    def pct(e: float, name: str) -> str:
        share = 100 * e / peak[name]
        return f'{e:.3g} N ({share:.0f} %)' if share >= 10 else f'{e:.3g} N ({share:.2g} %)'

    effects = table(['variant', 'kind', 'median us', 'p99 us']
                    + [f'max force error, {name}' for name in machine.bench_motions],
                    [[f'`{v.key}`', v.kind, f'{timing[v.key][0]:.1f}', f'{timing[v.key][1]:.1f}']
                     + ['absent from the model' if v.absent else
                        pct(errors[v.key][name], name) for name in machine.bench_motions]
                     for v in vs])
    absent = [v for v in vs if v.absent]
    if absent:
        effects += ('\n\nnote: effects absent from this model ('
                    + '; '.join(v.absent for v in absent) + '): the rows of '
                    + ', '.join(f'`{v.key}`' for v in absent) + ' time the computing of '
                    'nothing; the --params file gives these parameters to model them')
    estimator = table(['streamed', 'estimator', 'rate Hz', f'max force error, {focus}'],
                      [[s, m, f'{r:g}', pct(e, focus)] for s, m, r, e in estimates])
    points = [(v.key, 'absent' if v.absent else v.kind, errors[v.key][focus], timing[v.key][0])
              for v in vs]
    points += [(f'full, {s} at {r:g} Hz', 'estimated', e, timing['full'][0])
               for s, m, r, e in estimates if m == FIGURE_ESTIMATOR]
    return Measured(effects=effects, estimator=estimator, peak=peak, focus=focus,
                    points=points, kernel=machine.kernel_enabled())


def configure(p: argparse.ArgumentParser) -> None:
    p.add_argument('--cycles', type=int, default=10_000, metavar='N',
                   help='timed fsd.solve calls per variant (default 10000)')
    p.add_argument('--error-rate', type=float, default=1000.0, metavar='HZ',
                   help='sampling rate of the motions for the force errors (default 1000)')
    p.add_argument('--quick', action='store_true',
                   help='a smoke run (500 cycles, 200 Hz errors): figures only rough')
    where = p.add_mutually_exclusive_group()
    where.add_argument('--out-dir', default=None, metavar='DIR',
                       help=f'where scenes.md and scenes.png go (default {DEFAULT_OUT_DIR})')
    where.add_argument('--update-docs', action='store_true',
                       help=f'write them to {DOCS_DIR}/ (run from the repository root; the '
                            'packaged default machine only)')
    p.add_argument('--no-plot', action='store_true', help='do not write scenes.png')
    p.add_argument('--params', metavar='YAML', default=None,
                   help='parameter file, which names the machine (default: the packaged '
                        'parameters); its scenes are the packaged ones')


def run(args: argparse.Namespace) -> int:
    """The ``bench`` subcommand; returns 0."""
    command = shlex.join(['flight-sim-dynamics', 'bench', *getattr(args, 'argv', [])])
    if args.quick:
        args.cycles, args.error_rate = 500, 200.0
    if args.cycles < 1 or not (math.isfinite(args.error_rate) and args.error_rate >= 10.0):
        raise ValueError('--cycles must be >= 1 and --error-rate >= 10 Hz')
    out_dir = args.out_dir or DEFAULT_OUT_DIR
    if args.update_docs:
        if args.params is not None:
            raise ValueError('--update-docs writes the packaged default machine\'s page; give '
                             '--out-dir with --params')
        if not os.path.isfile(os.path.join(DOCS_DIR, 'scenes.md')):
            raise ValueError(f'--update-docs: no {DOCS_DIR}/scenes.md here; run it from the '
                             'repository root, or give --out-dir')
        out_dir = DOCS_DIR
    os.makedirs(out_dir, exist_ok=True)
    m = measure(args.params, args.cycles, args.error_rate)
    text = '\n\n'.join([
        '# What each effect costs and buys: scenes and effects',
        f'Time of one `fsd.solve` ({args.cycles} calls per variant, interleaved) against '
        f'the actuator-force error relative to `full`, motions sampled at '
        f'{args.error_rate:g} Hz; peak force of `full`: '
        + ', '.join(f'{n} {p:.1f} N' for n, p in m.peak.items()) + '.',
        m.effects, '## Missing accelerations',
        'The `full` model solved with the rates and accelerations the node estimates '
        f'(after the first {STARTUP_SAMPLES} samples) against the exact ones.', m.estimator,
        *([] if args.no_plot else [
            '![max force error and time per cycle of each variant](scenes.png)',
            'The figure: one bar per variant (orange: `full` on estimated rates and '
            'accelerations), most accurate first; left, the max |force error| '
            f'against `full` on the {m.focus} motion (log scale, "exact" for 0 N; for `payload` '
            'and `full + friction` the size of what they add); right, the median time per '
            'cycle.']),
        '## Machine and command',
        f'`{command}`; {platform.processor() or platform.machine()}, {os.cpu_count()} CPUs, '
        f'load average {os.getloadavg()[0]:.2f}; Python {platform.python_version()}, numpy '
        f'{np.__version__}; compiled kernel {"on" if m.kernel else "off"}.'])
    with open(os.path.join(out_dir, 'scenes.md'), 'w') as f:
        f.write(text + '\n')
    if not args.no_plot:
        plot(m.points, m.peak[m.focus], os.path.join(out_dir, 'scenes.png'), m.focus)
    print(m.effects + '\n\n' + m.estimator)
    print(f'wrote {os.path.join(out_dir, "scenes.md")}'
          + ('' if args.no_plot else ' and scenes.png'), file=sys.stderr)
    return 0
