"""The digital twin's figures (flight_sim_dynamics.core.simulation, docs/twin.md).

* speed: the real-time factor of the closed loop (RK4 at 1 kHz, the
  ``violent`` motion, full feed-forward, the full plant) and of the open loop
  in this process through the public API, with the compiled kernel (M, b and
  the RK4 loop in C) and with the Python code (``kernel.use_kernel(False)``,
  as FSD_KERNEL=0; timed on the motion's first FALLBACK_SECONDS, it is slow)
  in the same run, and the cost of one RK4 stage on each path;
* what accuracy buys: the tracking error (max and RMS; surge, heave, roll and
  leg lengths) of the closed loop on the paper's three motions and on
  ``violent``, for the feed-forward of every packaged scene and for none, at
  one servo bandwidth (default gains: a critically damped leg of the plant's
  leg-space mass, :meth:`Servo.for_bandwidth`), the plant the full model with
  the packaged limits; as a table and as a figure (twin_tracking.png next to
  the page);
* open-loop error growth: the inverse-dynamics forces of a 6 s motion near
  the workspace's edge (:func:`edge_motion`) fed back open loop, RK4 at 1 kHz:
  the largest pose error up to every 0.5 s, and a figure of it over time
  (twin_open_loop.png; not in ``--quick``).

Prints figures and tables; writes them to out/twin.md (the figures to
out/twin_tracking.png and out/twin_open_loop.png), or with ``--update-docs``
between the markers of docs/twin.md (the figures to docs/).

    python -m benchmarks.twin [--bandwidth 5] [--repeats 31] [--quick] [--update-docs]
"""
from __future__ import annotations

import argparse
import math
import statistics
import sys
import time
from dataclasses import replace
from pathlib import Path
from typing import Sequence

import numpy as np

import flight_sim_dynamics as fsd
from flight_sim_dynamics.cli.bench_report import machine_header
from flight_sim_dynamics.cli.csv_io import atomic_output
from flight_sim_dynamics.config.scenes import available_scenes
from flight_sim_dynamics.core import forward_dynamics as fd
from flight_sim_dynamics.core import kernel
from flight_sim_dynamics.core.motions import TEST_MOTIONS, get
from flight_sim_dynamics.core.reference_tables import reference_tables
from flight_sim_dynamics.core.simulation import (DEFAULT_BANDWIDTH_HZ, DEFAULT_DAMPING,
                                                 DEFAULT_STEP, Reference, Servo, TabulatedLaw,
                                                 integrate, simulate, step_count)

ROOT = Path(__file__).resolve().parents[1]
FIGURE = 'twin_tracking.png'
#: Simulated seconds timed on the Python code (2 to 3 s of wall time a run);
#: --quick: a tenth.
FALLBACK_SECONDS = 0.5
#: Timed runs of the Python code at most (each takes seconds).
PYTHON_REPEATS = 3
DEFAULT_OUT = Path('out') / 'twin.md'
DOCS = ROOT / 'docs' / 'twin.md'
BEGIN, END = '<!-- twin-benchmark:begin -->', '<!-- twin-benchmark:end -->'
EDGE_DURATION = 6.0
#: The edge motion: (offset, amplitude, frequency Hz) per coordinate; every
#: sample ok, strokes up to 0.549 m of the 0.6 m limit.
EDGE_TERMS = ((0.0, 0.1, 0.35), (0.3, 0.15, 0.25), (0.0, 0.3, 0.3))


def edge_motion(t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """q, qd, qdd (each (N, 3)) of offset + amplitude sin(2 pi f t) per coordinate."""
    t = np.atleast_1d(np.asarray(t, dtype=float))[:, None]
    offset, amplitude, hz = (np.array(c) for c in zip(*EDGE_TERMS))
    w = 2.0 * math.pi * hz
    return (offset + amplitude * np.sin(w * t), amplitude * w * np.cos(w * t),
            -amplitude * w * w * np.sin(w * t))


def table(header: Sequence[str], rows: Sequence[Sequence[str]]) -> str:
    lines = ['| ' + ' | '.join(header) + ' |',
             '| ' + ' | '.join([':---'] + ['---:'] * (len(header) - 1)) + ' |']
    lines += ['| ' + ' | '.join(row) + ' |' for row in rows]
    return '\n'.join(lines) + '\n'


#: The machine-speed probe: a fixed pure-Python loop (about 2 ms), timed before
#: every timed run. On the shared 2-core machine of docs/twin.md its speed
#: drops to 60 % of its best for seconds at a time, and every figure with it.
PROBE = 100_000


def _probe() -> float:
    start = time.perf_counter()
    sum(range(PROBE))
    return time.perf_counter() - start


def _real_time_factor(call, repeats: int, probes: list[float]) -> tuple[str, fsd.Simulation]:
    """Simulated seconds (up to where the run ends or stops) per wall-clock
    second, the median of ``repeats`` runs and the best (on a shared machine
    the best is what the code can do, the median what it did); the last run.
    Appends the probe's time before each run to ``probes``.
    """
    factors = []
    for _ in range(repeats):
        probes.append(_probe())
        start = time.perf_counter()
        sim = call()
        factors.append((sim.t[-1] - sim.t[0]) / (time.perf_counter() - start))
    digits = 1 if max(factors) >= 10 else 2
    return f'{statistics.median(factors):.{digits}f} (best {max(factors):.{digits}f})', sim


def speed_rows(plant: fsd.Model, repeats: int, motion: str, fallback_s: float
               ) -> list[list[str]]:
    """Real-time factors (median and best of ``repeats`` runs; the Python code
    on the first ``fallback_s`` seconds, at most PYTHON_REPEATS runs), the
    machine's speed while timing (:data:`PROBE`) and per-stage costs, kernel
    and Python code in the same process.
    """
    reference = get(motion)
    head = replace(Reference.from_motion(reference), end=fallback_s)
    t, q, qd, qdd = reference.sampled(1000.0)
    forces = (t, fsd.solve_batch(plant, q, qd, qdd).force)
    rows = int(round(fallback_s * 1000.0)) + 1
    head_forces = (t[:rows], forces[1][:rows])
    factors, probes = [], []
    for on in (True, False):
        runs = repeats if on else min(repeats, PYTHON_REPEATS)
        with kernel.use_kernel(on):
            factors.append(
                (_real_time_factor(lambda: simulate(plant, reference=reference if on else head,
                                                    feedforward=plant), runs, probes),
                 _real_time_factor(lambda: simulate(plant, forces=forces if on else head_forces),
                                   runs, probes)))
    speed = [min(probes) / p for p in probes]
    state = (q[len(q) // 2], qd[len(q) // 2])
    M, b, _ = fd.affine_terms(plant, *state)
    with kernel.use_kernel(False):
        python_mb = _time_us(lambda: fd.affine_terms(plant, *state), 200)
    stage = [_time_us(lambda: fd.affine_terms(plant, *state)),
             _time_us(lambda: fd.solve_accelerations(M, b, b)),
             _time_us(lambda: fsd.solve(plant, state[0], state[1], (0.0, 0.0, 0.0)))]
    ((closed, _), (opened, run)), ((closed_py, _), (opened_py, _)) = factors
    with kernel.use_kernel(True):
        phases = phase_row(plant, motion, repeats)
    python = f'Python code (FSD_KERNEL=0), first {fallback_s:g} s'
    stops = '' if run.outcome == 'ok' else f' (it stops at {run.t[-1]:.3g} s: {run.outcome})'
    return [[f'closed loop, RK4 1 kHz, {motion}, full feed-forward: real-time factor',
             closed],
            ['machine speed while timing: a fixed Python loop before each run, median / '
             'slowest, of its best', f'{statistics.median(speed):.0%} / {min(speed):.0%}'],
            phases,
            [f'the same, {python}', closed_py],
            [f'open loop, RK4 1 kHz, {motion}: real-time factor{stops}', opened],
            [f'the same, {python}', opened_py],
            ['M and b (`affine_terms`, one kernel call): median per stage',
             f'{stage[0]:.1f} us'],
            ['M and b (`affine_terms`, Python code: four solves): median per stage',
             f'{python_mb:.0f} us'],
            ['cond(M) and LU solve (numpy; the Python loop): median per stage',
             f'{stage[1]:.1f} us'],
            ['one `fsd.solve`: median', f'{stage[2]:.1f} us']]


def phase_row(plant: fsd.Model, motion: str, repeats: int) -> list[str]:
    """The phases of one closed-loop run through the kernel, each timed alone
    (median of ``repeats``), as ``simulate`` would run them one after another
    (it overlaps all but the first and the RK4 loop on the worker threads).
    """
    reference = Reference.from_motion(get(motion))
    steps = step_count(reference.start, reference.end, DEFAULT_STEP)
    times = reference.start + 0.5 * DEFAULT_STEP * np.arange(2 * steps + 1)
    motion_ms, (q, qd, qdd) = _time_ms(lambda: reference.motion(times), repeats)
    tables_ms, (length, rate, force) = _time_ms(
        lambda: reference_tables(plant, q, qd, qdd, times, motion), repeats)
    law = TabulatedLaw.servo_law(plant, Servo.for_bandwidth(plant), force, length, rate)
    loop_ms, run = _time_ms(lambda: integrate(plant, reference.start, DEFAULT_STEP, steps,
                                              q[0], qd[0], law), repeats)
    result_ms, _ = _time_ms(lambda: fsd.solve_batch(plant, *run[1:4]), repeats)
    return ['the closed loop\'s phases, each alone: reference motion / reference tables / '
            'RK4 loop / result rows (median)',
            f'{motion_ms:.1f} / {tables_ms:.1f} / {loop_ms:.1f} / {result_ms:.1f} ms']


def _time_ms(call, repeats: int) -> tuple[float, object]:
    """Median wall time (ms) of ``repeats`` calls, and the last result."""
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        out = call()
        times.append(time.perf_counter() - start)
    return statistics.median(times) * 1e3, out


def _time_us(call, n: int = 2000) -> float:
    times = []
    for _ in range(n):
        start = time.perf_counter_ns()
        call()
        times.append(time.perf_counter_ns() - start)
    return statistics.median(times) / 1e3


def tracking(plant: fsd.Model, servo: Servo, motions: Sequence[str],
             scenes: Sequence[str]) -> dict[tuple[str, str], fsd.Simulation]:
    """The closed loop of every (motion, feed-forward scene or 'none')."""
    runs = {}
    for name in motions:
        for scene in (*scenes, 'none'):
            feedforward = None if scene == 'none' else fsd.load_model(scene=scene)
            runs[name, scene] = simulate(plant, reference=get(name), feedforward=feedforward,
                                         servo=servo)
    return runs


def tracking_rows(runs: dict[tuple[str, str], fsd.Simulation]) -> list[list[str]]:
    """One row per (motion, feed-forward): max / RMS errors, mm and mrad."""
    rows = []
    for (name, scene), sim in runs.items():
        e = sim.tracking()
        cells = [f"{1e3 * e[f'{k}_max']:.3g} / {1e3 * e[f'{k}_rms']:.3g}"
                 for k in ('surge', 'heave', 'roll', 'length')]
        rows.append([name, scene, *cells, f'{np.max(np.abs(sim.rate)):.2f}',
                     f'{np.max(np.abs(sim.force)):.0f}', str(sim.outcome)])
    return rows


def plot_tracking(runs: dict[tuple[str, str], fsd.Simulation], title: str, path: Path) -> None:
    """Leg-length tracking error, max (bar) and RMS (dot), per motion and
    feed-forward, on a log axis (the full model's errors are round-off).
    """
    from matplotlib.figure import Figure

    motions = list(dict.fromkeys(name for name, _ in runs))
    scenes = list(dict.fromkeys(scene for _, scene in runs))
    fig = Figure(figsize=(9.0, 1.2 + 0.45 * len(runs) + 0.3 * len(motions)), dpi=110,
                 layout='constrained')
    ax = fig.subplots()
    others = iter(('tab:blue', 'tab:green', 'tab:orange', 'tab:red', 'tab:purple', 'tab:brown'))
    colours = {scene: {'full': 'black', 'none': 'tab:gray'}.get(scene) or next(others, 'tab:olive')
               for scene in scenes}
    labels, y = [], 0.0
    for name in motions:
        for scene in scenes:
            e = runs[name, scene].tracking()
            worst, rms = max(1e3 * e['length_max'], 1e-12), max(1e3 * e['length_rms'], 1e-12)
            ax.barh(y, worst, left=1e-13, color=colours[scene], height=0.8)
            ax.plot(rms, y, 'o', color='white', markeredgecolor='black', markersize=5)
            ax.text(worst * 1.3, y, f'{worst:.2g}', va='center', fontsize=7.5)
            labels.append((y, f'{name}: {scene}'))
            y += 1.0
        y += 0.6
    ax.set_xscale('log')
    ax.set_xlim(1e-11, 3e3)
    ax.set_yticks([p for p, _ in labels], [text for _, text in labels], fontsize=8)
    ax.invert_yaxis()
    ax.grid(True, axis='x', which='major', alpha=0.3)
    ax.set_xlabel('leg length tracking error, mm (bar: max, dot: RMS; log scale)')
    ax.set_title(title, fontsize='medium')
    with atomic_output(path) as f:
        fig.savefig(f, format='png')


def open_loop_edge(plant: fsd.Model) -> tuple[fsd.Simulation, np.ndarray, fsd.Solution]:
    """Open loop on the edge motion, fed its inverse-dynamics forces: the run,
    its pose error against the motion per row, the motion's solve.
    """
    t = np.arange(int(round(EDGE_DURATION * 1000)) + 1) / 1000.0
    q, qd, qdd = edge_motion(t)
    sol = fsd.solve_batch(plant, q, qd, qdd)
    sim = simulate(plant, forces=(t, sol.force), initial=(q[0], qd[0]))
    return sim, np.abs(sim.q - q[:len(sim.t)]), sol


def growth_rows(sim: fsd.Simulation, error: np.ndarray, sol: fsd.Solution,
                step_s: float = 0.5) -> list[list[str]]:
    """The largest pose error of :func:`open_loop_edge` up to every 0.5 s."""
    rows = []
    for end in np.arange(step_s, EDGE_DURATION + 1e-9, step_s):
        upto = sim.t <= end + 1e-9
        if sim.t[-1] + 1e-9 < end:
            rows.append([f'{end:.1f}', '-', '-', f'stopped at {sim.t[-1]:.3f} s: {sim.outcome}'])
            break
        rows.append([f'{end:.1f}', f'{error[upto, :2].max():.2e}', f'{error[upto, 2].max():.2e}',
                     str(sim.outcome) if end >= EDGE_DURATION - 1e-9 else ''])
    peak = ['peak condition (kinematic / Jacobian) on the motion',
            f'{np.max(sol.kinematic_condition):.3g} / {np.max(sol.jacobian_condition):.3g}']
    statuses = ', '.join(sorted({str(s) for s in sol.status}))
    return rows + [[peak[0], peak[1], '', ''], ['statuses of the motion', statuses, '', '']]


def plot_growth(sim: fsd.Simulation, error: np.ndarray, path: Path) -> None:
    """The open-loop pose error of :func:`open_loop_edge` over time, log scale."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(7.0, 3.2), dpi=110, layout='constrained')
    ax = fig.subplots()
    floor = 1e-16
    for column, label in ((0, 'surge, m'), (1, 'heave, m'), (2, 'roll, rad')):
        ax.semilogy(sim.t, np.maximum(error[:, column], floor), label=label, linewidth=1.0)
    ax.set_xlabel('time, s')
    ax.set_ylabel('open-loop pose error')
    ax.set_title('Open loop under the inverse-dynamics forces, 6 s motion near the '
                 'workspace edge', fontsize='small')
    ax.grid(True, which='major', alpha=0.3)
    ax.legend(fontsize='small')
    with atomic_output(path) as f:
        fig.savefig(f, format='png')


def report(args: argparse.Namespace, argv: Sequence[str], figure: Path) -> str:
    """The page (markdown); writes the tracking figure to ``figure`` and the
    open-loop growth figure beside it.
    """
    plant = fsd.load_model()
    servo = Servo.for_bandwidth(plant, args.bandwidth, DEFAULT_DAMPING)
    motions = ('vertical',) if args.quick else TEST_MOTIONS
    scenes = ('full',) if args.quick else tuple(available_scenes())
    setup = (f'Servo: {args.bandwidth:g} Hz, damping {DEFAULT_DAMPING:g}: kp = '
             + ', '.join(f'{k:.0f}' for k in servo.kp) + ' N/m, kd = '
             + ', '.join(f'{k:.0f}' for k in servo.kd) + ' N s/m (legs A, B, C); plant: '
             f'full model, limits {plant.limits.max_force:g} N, '
             f'{plant.limits.max_speed:g} m/s; RK4 step 1 ms')
    runs = tracking(plant, servo, motions, scenes)
    plot_tracking(runs, f'What accuracy buys: tracking by feed-forward scene '
                  f'(servo {args.bandwidth:g} Hz, damping {DEFAULT_DAMPING:g})', figure)
    fallback = FALLBACK_SECONDS / 10 if args.quick else FALLBACK_SECONDS
    out = [setup + '\n',
           '### Speed\n', table(['figure', 'value'],
                                speed_rows(plant, args.repeats, 'vertical' if args.quick
                                           else 'violent', fallback)),
           '### Tracking error by feed-forward scene\n',
           table(['motion', 'feed-forward', 'surge max / RMS mm', 'heave max / RMS mm',
                  'roll max / RMS mrad', 'leg length max / RMS mm', 'peak leg rate m/s',
                  'peak force N', 'outcome'], tracking_rows(runs)),
           f'![leg length tracking error by motion and feed-forward scene]({figure.name})\n']
    if not args.quick:
        sim, error, sol = open_loop_edge(plant)
        growth_figure = figure.with_name('twin_open_loop.png')
        plot_growth(sim, error, growth_figure)
        out += ['### Open-loop error growth, 6 s motion near the workspace edge\n',
                table(['up to t s', 'surge/heave max error m', 'roll max error rad', 'note'],
                      growth_rows(sim, error, sol)),
                f'![open-loop pose error over time]({growth_figure.name})\n']
    out += ['### Machine and command\n', '\n'.join(machine_header(argv)).replace(
        'flight-sim-dynamics bench', 'python -m benchmarks.twin') + '\n']
    return '\n'.join(out)


def write(text: str, update_docs: bool, out: str) -> str:
    if not update_docs:
        path = Path(out)
        path.parent.mkdir(parents=True, exist_ok=True)
        with atomic_output(path) as f:
            f.write(text.encode())
        return str(path)
    doc = DOCS.read_text()
    try:
        head, rest = doc.split(BEGIN, 1)
        _, tail = rest.split(END, 1)
    except ValueError:
        raise SystemExit(f'{DOCS}: markers {BEGIN} ... {END} not found') from None
    with atomic_output(DOCS) as f:
        f.write(f'{head}{BEGIN}\n{text}{END}{tail}'.encode())
    return str(DOCS)


def main(argv: Sequence[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    p = argparse.ArgumentParser(prog='python -m benchmarks.twin',
                                description=__doc__.split('\n\n')[0])
    where = p.add_mutually_exclusive_group()
    where.add_argument('--out', default=str(DEFAULT_OUT), metavar='MD',
                       help=f'page to write (default {DEFAULT_OUT})')
    where.add_argument('--update-docs', action='store_true',
                       help='write between the markers of docs/twin.md instead')
    p.add_argument('--bandwidth', type=float, default=DEFAULT_BANDWIDTH_HZ, metavar='HZ',
                   help=f'servo bandwidth of the gains (default {DEFAULT_BANDWIDTH_HZ:g} Hz)')
    p.add_argument('--repeats', type=int, default=31,
                   help=f'timed runs, median of (31; the Python code: at most {PYTHON_REPEATS})')
    p.add_argument('--quick', action='store_true',
                   help='smoke run: one motion, one scene, no growth table (figures meaningless)')
    args = p.parse_args(argv)
    if not (math.isfinite(args.bandwidth) and args.bandwidth > 0) or args.repeats < 1:
        p.error('--bandwidth must be > 0 and --repeats >= 1')
    page = DOCS if args.update_docs else Path(args.out)
    page.parent.mkdir(parents=True, exist_ok=True)
    text = report(args, argv, page.parent / FIGURE)
    print(text)
    print(f'wrote {write(text, args.update_docs, args.out)}', file=sys.stderr)
    return 0


if __name__ == '__main__':
    sys.exit(main())
