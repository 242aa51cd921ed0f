"""The report of ``flight-sim-dynamics bench``: tables, the markdown page
(``scenes.md``) and the figure (``scenes.png``: time per cycle against
force error, one point per variant). Figures and tables only: what they mean
is for people to write.
"""
from __future__ import annotations

import datetime
import io
import math
import os
import platform
import shlex
from typing import Sequence

import numpy as np

import flight_sim_dynamics as fsd

from ..core import kernel
from ..core.motions import MOTIONS as REGISTRY
from ..core.motions import TEST_MOTIONS as MOTIONS
from ..core.motions import VIOLENT_STEPS, sample_times
from .bench_cases import (ADDS, DROPS, ESTIMATOR_MOTIONS, REFERENCE, SCENE, SIGNIFICANCE,
                          STARTUP_SAMPLES, ForceError, Results, Variant)
from .csv_io import atomic_output

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


def load_average() -> str:
    try:
        return ' '.join(f'{x:.2f}' for x in os.getloadavg())
    except (AttributeError, OSError):
        return '?'


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
    load = load_average()
    return [
        f'- date: {datetime.datetime.now(datetime.timezone.utc):%Y-%m-%d %H:%M UTC}',
        f'- command: `{(env + " ") if env else ""}{command}`',
        f'- processor: `{platform.processor() or "(empty)"}` ({platform.machine()}), CPU model: '
        f'{cpu or "?"}, {os.cpu_count()} logical cores ({usable} usable by this process)',
        f'- Python {platform.python_version()} ({platform.python_implementation()}), '
        f'numpy {np.__version__}, {platform.system()} {platform.release()}',
        f'- load average at start (1, 5, 15 min): {load}',
    ]


def summary_table(res: Results) -> str:
    """The headline figures of the run, one row each."""
    ref = res.timing['full']
    rows = [['`fsd.solve`, full model: median / p99 of a typical block',
             f'{ref.median_us:.1f} / {ref.block_p99_us:.1f} us'],
            ['`solve_batch`, full model', f'{1e6 / res.throughput["full"]:.2f} us per sample'],
            ['`sol.cond` (exact cond(Q), SVD): added to a solve',
             f'{res.timing["full + cond(Q)"].paired_delta_us(ref)[0]:+.1f} us']]
    rows += [[f'peak actuator force, {m}', f'{res.peaks[m]:.1f} N'] for m in MOTIONS]
    for v in res.variants:
        if v.kind != REFERENCE:
            delta, p_value = res.timing[v.key].paired_delta_us(ref)
            rows.append([f'`{v.key}`: time vs full / max force diff on violent',
                         f'{_fmt_delta(delta, p_value)} us / '
                         f'{_fmt_err(res.errors[v.key]["violent"])}'])
    for c in res.estimators:
        if c.method == 'backward2':
            src = 'pose + twist' if c.source == 'twist' else 'pose only'
            rows.append([f'estimator backward2, {src}, {c.rate:.0f} Hz: max force error on '
                         'violent', _fmt_err(c.steady['violent'])])
    return _table(['figure', 'value'], rows)


def markdown(res: Results, header_lines: list[str], load_end: str) -> str:
    full = res.timing['full']
    buf = io.StringIO()
    w = buf.write
    w('# What accuracy costs in time: scenes and effects\n\n')
    w('## Summary\n\n')
    w(summary_table(res) + '\n\n')
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
    w(f'- max |force| difference `solve_batch` vs `solve` over the test samples: '
      f'{res.max_abs_batch_vs_single:.0e} N\n')
    w(f'- `solve_batch`, full model: {res.throughput["full"] / 1e3:.0f} k samples/s, '
      f'{1e6 / res.throughput["full"]:.1f} us per sample; one `solve`: '
      f'{full.median_us:.1f} us\n\n')

    w('## The test motions\n\n')
    w(motions_table(res) + '\n\n')
    w('## The violent motion\n\n')
    w('The steps of `violent` (`flight_sim_dynamics.core.motions.VIOLENT_STEPS`), each a '
      'quintic smooth step `s(u) = 10u^3 - 15u^4 + 6u^5`, `u = (t - start) / duration`, of '
      'the coordinate by `change` (the steps of one coordinate add up):\n\n')
    rows = [[['surge', 'heave', 'roll'][a], f'{s:.2f}', f'{d:.2f}',
             f'{c:+.2f} {"rad" if a == 2 else "m"}',
             f'{5.7735 * abs(c) / d ** 2:.1f} {"rad/s^2" if a == 2 else "m/s^2"}']
            for a, s, d, c in VIOLENT_STEPS]
    w(_table(['coordinate', 'start (s)', 'duration (s)', 'change', 'peak acc. of the step'],
             rows, ['l', 'r', 'r', 'r', 'r']) + '\n')
    return buf.getvalue()


def motions_table(res: Results) -> str:
    """Per test motion (1 kHz): duration, peak accelerations, ranges, peak
    rates, and the full model's actuator speeds and strokes.
    """
    full = res.variants[0].model
    header = ['motion', 'duration (s)', 'peak acc. surge, heave (m/s^2)', 'peak acc. roll '
              '(rad/s^2)', 'surge range (m)', 'heave range (m)', 'roll range (rad)',
              'peak rates (m/s, m/s, rad/s)', 'peak actuator speed (m/s)', 'strokes (m)']
    rows = []
    for name in MOTIONS:
        motion = REGISTRY[name]
        t = sample_times(1000.0, motion.duration)
        q, qd, qdd = motion.trajectory(t)
        sol = fsd.solve_batch(full, q, qd, qdd)
        rows.append([f'`{name}`', f'{motion.duration:g}',
                     f'{np.abs(qdd[:, 0]).max():.2f}, {np.abs(qdd[:, 1]).max():.2f}',
                     f'{np.abs(qdd[:, 2]).max():.2f}']
                    + [f'{q[:, i].min():+.2f}..{q[:, i].max():+.2f}' for i in range(3)]
                    + [', '.join(f'{np.abs(qd[:, i]).max():.2f}' for i in range(3)),
                       f'{np.abs(sol.rate).max():.2f}',
                       f'{sol.stroke.min():+.2f}..{sol.stroke.max():+.2f}'])
    return _table(header, rows, ['l'] + ['r'] * (len(header) - 1))


def plot(res: Results, path: str) -> None:
    """Two panels sharing one row per variant, sorted by accuracy: the max force
    error on the violent motion (log x; "exact" for 0 N) and the median time
    per cycle. Names sit on the axis, so no label can hide another.
    """
    from matplotlib.figure import Figure
    from matplotlib.patches import Patch

    full_us = res.timing['full'].median_us
    rows = [(v.key, res.errors[v.key]['violent'].max, res.timing[v.key].median_us, v.kind)
            for v in res.variants]
    rows.append(('full + cond(Q) diagnostic', 0.0, res.timing['full + cond(Q)'].median_us,
                 'diagnostic'))
    for c in res.estimators:
        if c.method == 'backward2':
            key = f'estimator backward2, {"pose + twist" if c.source == "twist" else "pose only"}'
            name = (f'full, {"qdd" if c.source == "twist" else "qd and qdd"} estimated at '
                    f'{c.rate:.0f} Hz')
            rows.append((name, c.steady['violent'].max,
                         full_us + res.timing[key].median_us, f'estimated ({c.source})'))
    rows.sort(key=lambda r: (r[1], r[0]))
    positive = [r[1] for r in rows if r[1] > 0]
    floor = 10 ** (math.floor(math.log10(min(positive))) - 1) if positive else 1e-3
    colours = {REFERENCE: 'black', SCENE: 'tab:blue', DROPS: 'tab:red', ADDS: 'tab:green',
               'diagnostic': 'tab:purple', 'estimated (twist)': 'tab:orange',
               'estimated (pose)': 'tab:brown'}
    meaning = {REFERENCE: 'full model (reference)', SCENE: 'packaged scene',
               DROPS: 'full without one effect', ADDS: 'adds a body or an effect',
               'diagnostic': 'full + exact cond(Q) (SVD)',
               'estimated (twist)': 'accelerations estimated from twists (backward2)',
               'estimated (pose)': 'rates and accelerations estimated from poses (backward2)'}
    fig = Figure(figsize=(11.0, 0.32 * len(rows) + 2.2), dpi=110, layout='constrained')
    ax_e, ax_t = fig.subplots(1, 2, sharey=True, width_ratios=(3, 2))
    y = np.arange(len(rows))
    colour = [colours[r[3]] for r in rows]
    ax_e.barh(y, [max(r[1], floor) for r in rows], left=floor / 10, color=colour)
    for k, r in enumerate(rows):
        ax_e.text(max(r[1], floor) * 1.15, k, 'exact' if r[1] == 0 else f'{r[1]:.3g} N',
                  va='center', fontsize=8)
    ax_e.set_xscale('log')
    ax_e.set_xlim(floor / 10, max(positive, default=1.0) * 20)
    ax_e.set_yticks(y, [r[0] for r in rows], fontsize=8.5)
    ax_e.set_xlabel(f'max |force error| vs full model on the violent motion (N; peak force '
                    f'{res.peaks["violent"]:.0f} N)')
    ax_t.barh(y, [r[2] for r in rows], color=colour)
    for k, r in enumerate(rows):
        ax_t.text(r[2], k, f' {r[2]:.1f} us', va='center', fontsize=8)
    ax_t.set_xlim(0, max(r[2] for r in rows) * 1.25)
    ax_t.set_xlabel('median time per cycle, fsd.solve (us)')
    for ax in (ax_e, ax_t):
        ax.grid(True, axis='x', which='both', alpha=0.3)
        ax.invert_yaxis()
    ax_t.invert_yaxis()         # shared y: invert once
    kinds = list(dict.fromkeys(r[3] for r in rows))
    fig.legend([Patch(color=colours[k]) for k in kinds], [meaning[k] for k in kinds],
               loc='outside lower center', ncol=3, fontsize=8, frameon=False)
    fig.suptitle('What accuracy costs in time: every variant, most accurate first',
                 fontsize='medium')
    with atomic_output(path) as f:
        fig.savefig(f, format='png')


def write_text(path: str, text: str) -> None:
    """Write ``text`` to ``path`` (whole or not at all)."""
    with atomic_output(path) as f:
        f.write(text.encode())


