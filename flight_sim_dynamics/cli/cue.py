"""``flight-sim-dynamics cue``: a vehicle log through the motion-cueing planner
(:func:`flight_sim_dynamics.cueing.planner.run`: the washout and the limiter of
the ``cueing`` group of ``--params``), written as the machine's trajectory CSV
at ``cueing.rate`` (the columns ``solve`` and ``simulate`` read); a result line;
on request the cue report (markdown table, :mod:`flight_sim_dynamics.cueing.metrics`)
and its figure. ``--example NAME`` writes a built-in vehicle log to try it.

    flight-sim-dynamics cue --example violent -o violent.csv
    flight-sim-dynamics cue violent.csv --params config/<name>.yaml
        -o platform.csv --report cue.md --plot cue.png
"""
from __future__ import annotations

import argparse
import math
import os
import sys
from typing import Any, Sequence

import numpy as np

import flight_sim_dynamics as fsd

from ..config.machine_files import load_cueing
from ..cueing.metrics import FORCE_THRESHOLDS, RATE_THRESHOLD, CueMetrics, cue_metrics
from ..config.cueing import LIMITERS, CueingParams
from ..cueing.planner import CueRun, SampleError, run as cue_run
from ..cueing.vehicles import VEHICLES, vehicle_log
from ..machines import MACHINES
from . import csv_io
from .columns import trajectory_columns
from .csv_io import CsvError
from .main import MAX_SAMPLES, CliError, load_model
from .progress import Progress

#: A vehicle log's columns (SI, body axes per REP-103); others are ignored.
VEHICLE_COLUMNS = ('t', 'f_x', 'f_y', 'f_z', 'omega_x', 'omega_y', 'omega_z')
#: Output samples from which progress lines are printed.
LONG_RUN = 200_000
#: Most points per curve of the figure.
PLOT_POINTS = 4000
AXES = ('x', 'y', 'z')


def configure(p: argparse.ArgumentParser) -> None:
    p.add_argument('input', nargs='?', metavar='VEHICLE_CSV',
                   help="vehicle log ('-' for standard input): " + ','.join(VEHICLE_COLUMNS)
                        + ' (specific force m/s^2 and angular velocity rad/s, vehicle body axes '
                        'per REP-103, at rest (0,0,9.80665); any rate, irregular; repeated '
                        'times dropped and counted; other columns ignored)')
    p.add_argument('-o', '--output', required=True, metavar='CSV',
                   help="platform trajectory CSV to write ('-' for standard output) at "
                        'cueing.rate: t, the coordinates, <coordinate>_rate, <coordinate>_acc '
                        "(a name ending in .npz: numpy's .npz, quicker for long logs); with "
                        '--example: the vehicle log')
    p.add_argument('--params', metavar='YAML', default=None,
                   help='parameter file naming the machine, its cueing group the planner '
                        f'(default: the packaged {MACHINES[0].title} and its set)')
    p.add_argument('--scene', metavar='NAME_OR_YAML', default=None,
                   help="effects the limiter's inverse dynamics models (default: the file's)")
    p.add_argument('--limiter', choices=LIMITERS, default=None,
                   help='instead of cueing.limiter: none gives the pure washout')
    p.add_argument('--report', metavar='MD', default=None,
                   help='write the cue metrics as a markdown table')
    p.add_argument('--plot', metavar='PNG', default=None,
                   help='write the figure: felt against vehicle cues over time, each leg\'s '
                        'force-speed points in its limit box (needs matplotlib)')
    p.add_argument('--example', metavar='NAME', default=None, choices=list(VEHICLES),
                   help='instead: write the built-in vehicle log NAME to -o ('
                        + ', '.join(VEHICLES) + ')')
    p.add_argument('--rate', type=float, default=1000.0, metavar='HZ',
                   help="--example's sampling rate (default 1000)")


def write_example(args: argparse.Namespace) -> int:
    if args.input is not None:
        raise CliError('--example writes a vehicle log: it takes no VEHICLE_CSV')
    if not (math.isfinite(args.rate) and 0 < args.rate <= 100_000):
        raise CliError(f'--rate must be a number of Hz in (0, 100000], got {args.rate:g}')
    log = vehicle_log(args.example, args.rate)
    csv_io.write_csv(args.output, VEHICLE_COLUMNS, np.column_stack([log.t, log.f, log.omega]))
    print(f'cue: wrote {args.output}: vehicle log {args.example!r}, {len(log.t)} samples at '
          f'{args.rate:g} Hz ({log.t[-1]:g} s)', file=sys.stderr)
    return 0


def read_vehicle(path: str) -> csv_io.Table:
    table = csv_io.read_csv(path, required=VEHICLE_COLUMNS, skip_extra=True)
    if table.skipped:
        print(f"note: {table.path}: ignoring column{'s' if len(table.skipped) > 1 else ''} "
              f"{', '.join(repr(n) for n in table.skipped)}", file=sys.stderr)
    return table


def params_of(args: argparse.Namespace) -> CueingParams:
    try:
        params = load_cueing(args.params)
    except fsd.ParameterError as exc:
        raise CliError(f"--params {args.params or '(packaged defaults)'}: {exc}") from None
    return params if args.limiter is None else params.replace(limiter=args.limiter)


def run(args: argparse.Namespace) -> int:
    if args.example is not None:
        return write_example(args)
    if args.input is None:
        raise CliError('expected a VEHICLE_CSV (or --example NAME -o FILE to write one)')
    for option in ('report', 'plot'):
        if getattr(args, option) in (args.input, args.output):
            raise CliError(f'--{option} {getattr(args, option)} is the input or the output')
    if args.plot is not None:
        from .plotting import output_format       # matplotlib: only for --plot
        fmt = output_format(args.plot)             # fail before the work
    model = load_model(args.params, args.scene, machines=MACHINES)
    params = params_of(args)
    machine = fsd.machine_of(model)
    table = read_vehicle(args.input)
    t = table['t']
    f = np.column_stack([table[n] for n in VEHICLE_COLUMNS[1:4]])
    omega = np.column_stack([table[n] for n in VEHICLE_COLUMNS[4:]])
    span = float(t.max() - t.min())
    if span * params.rate + 1 > MAX_SAMPLES:
        raise CsvError(f't spans {span:g} s: more than {MAX_SAMPLES} samples at cueing.rate = '
                       f'{params.rate:g} Hz (is t in seconds?)', path=table.path,
                       name='t')
    n_out = int(span * params.rate) + 1
    progress = (Progress(n_out, args.output, sys.stderr, 'cue', 'samples').done
                if n_out >= LONG_RUN else None)
    # a long log on two cores or more: the washout's stage and the CSV's formatting
    # each in a process of its own beside the limiter (docs/cli.md, cue)
    parallel = n_out >= LONG_RUN and len(os.sched_getaffinity(0)) > 1
    with csv_io.table_writer(args.output, trajectory_columns(machine),
                             parallel=parallel) as write:
        def block(times: np.ndarray, samples: np.ndarray) -> None:
            write(np.column_stack([times, samples]))     # written as the run goes
        try:
            result = cue_run(model, params, t, f, omega,
                             progress=None if progress is None else
                             lambda k, n, stage: progress(k, stage),
                             on_block=block, parallel=parallel)
        except SampleError as exc:
            raise CsvError(exc.reason, path=table.path, line=int(table.lines[exc.index]),
                           name='t') from None
    metrics = None
    if args.report is not None or args.plot is not None:
        metrics = cue_metrics(model, result, params)
    # the data on standard output: the result line goes to standard error
    print(result_line(machine, params, result, metrics, args.output),
          file=sys.stderr if args.output == '-' else sys.stdout)
    if result.repeated:
        print(f'note: {table.path}: {result.repeated} repeated time(s) dropped (the first '
              'sample of each kept)', file=sys.stderr)
    if args.report is not None:
        text = report(machine, params, result, metrics, args)
        with csv_io.atomic_output(args.report) as out:
            out.write(text.encode())
    if args.plot is not None:
        fig = figure(machine, params, result, metrics, os.path.basename(args.input))
        with csv_io.atomic_output(args.plot) as out:
            fig.savefig(out, format=fmt, dpi=100)
    return 0


def _limits_text(limits: dict[str, int]) -> str:
    return ', '.join(f'{name} {count}' for name, count in
                     sorted(limits.items(), key=lambda kv: -kv[1])) or 'none'


def _given_up(result: CueRun) -> tuple[float, float, dict[str, int]]:
    given = np.asarray(result.given_up, dtype=float)
    acted = np.array([bool(x) for x in result.limit], dtype=bool)
    names, counts = np.unique(np.asarray(result.limit[acted], dtype=str), return_counts=True)
    return (float((given > 0).mean()) if len(given) else 0.0,
            float(given.max()) if len(given) else 0.0, dict(zip(names.tolist(),
                                                              counts.tolist())))


def _limiter_text(params: CueingParams) -> str:
    """The limiter's name, and its preview (L8) when the run planned one."""
    s = params.limiter_settings
    if params.limiter == 'inverse_dynamics' and s['preview.slope'] > 0:
        return (f"{params.limiter} with the preview (slope {s['preview.slope']:g}/s, lead "
                f"{s['preview.lead']:g} s)")
    return params.limiter


def result_line(machine: Any, params: CueingParams, result: CueRun,
                metrics: CueMetrics | None, output: str) -> str:
    """One line: what was written, what the limiter did, and with the metrics
    the cue's error and the actuators' peaks against their limits.
    """
    n = len(result.t)
    fraction, peak, limits = _given_up(result)
    parts = [f'cue: {output}: {n} samples at {params.rate:g} Hz ({n / params.rate:.1f} s), '
             f'{machine.title}, limiter {_limiter_text(params)}']
    if params.limiter != 'none':
        parts.append(f'cue given up in {100 * fraction:.1f} % of samples (at most '
                     f'{100 * peak:.0f} %; limits: {_limits_text(limits)})')
    if result.dropped:
        parts.append('not cued: ' + ', '.join(result.dropped))
    if metrics is not None:
        legs, lim = metrics.legs, metrics.legs.limits
        parts.append('felt specific force RMSE ' + ' '.join(
            f'{a} {v:.3f}' for a, v in zip(AXES, metrics.force.rmse)) + ' m/s^2')
        parts.append(f'peak force {legs.peak_force.max():.0f} N (limit {lim.max_force:.0f}), '
                     f'peak speed {legs.peak_speed.max():.3f} m/s (limit {lim.max_speed:g}), '
                     f'stroke used {100 * legs.stroke_used.max():.0f} %')
        parts.append('solver: ' + ', '.join(f'{k} {v}' for k, v in legs.statuses.items()))
    if result.held:
        parts.append(f'{result.held} non-finite samples held')
    return '; '.join(parts)


def _row(name: str, values: Sequence[float], fmt: str) -> str:
    cells = ['n/a' if not math.isfinite(v) else format(v, fmt) for v in values]
    return f"| {name} | {' | '.join(cells)} |"


def report(machine: Any, params: CueingParams, result: CueRun, metrics: CueMetrics,
           args: argparse.Namespace) -> str:
    """The cue report (markdown): the cues per axis, the actuators per leg, the limiter."""
    m, legs, lim = metrics, metrics.legs, metrics.legs.limits
    fraction, peak, limits = _given_up(result)
    lines = [f'# Motion cueing: {args.input} on the {machine.title}', '',
             f'`flight-sim-dynamics cue {" ".join(getattr(args, "argv", []))}`', '',
             f'{m.samples} samples at {params.rate:g} Hz ({m.duration:.2f} s); limiter '
             f'{_limiter_text(params)}; head at '
             f'({", ".join(f"{v:g}" for v in params.head)}) m in the platform frame; '
             f'not cued: {", ".join(result.dropped) or "none"}; repeated input times dropped: '
             f'{result.repeated}.', '']
    if m.felt_samples < m.samples:
        lines += [f'The felt motion is known at {m.felt_samples} of the samples (the others '
                  'are not solved: see the solver statuses); the cue figures are theirs.', '']
    lines += ['## Cues at the head: felt against the vehicle', '',
              '| | x | y | z |', '|---|---|---|---|',
              _row('specific force RMSE (m/s²)', m.force.rmse, '.3f'),
              _row('specific force correlation', m.force.correlation, '.3f'),
              _row('specific force delay (s)', m.force.delay, '.3f'),
              _row(f'specific force false cues (% of samples; thresholds '
                   f'{"/".join(f"{v:g}" for v in FORCE_THRESHOLDS)} m/s²)',
                   100 * m.force.false_fraction, '.2f'),
              _row('angular velocity RMSE (deg/s)', np.degrees(m.rate.rmse), '.3f'),
              _row('angular velocity correlation', m.rate.correlation, '.3f'),
              _row('angular velocity delay (s)', m.rate.delay, '.3f'),
              _row(f'angular velocity false cues (% of samples; threshold '
                   f'{math.degrees(RATE_THRESHOLD):g} deg/s)', 100 * m.rate.false_fraction,
                   '.2f'),
              _row('specific force given up by the limiter, RMSE (m/s²)', m.given_up_rmse,
                   '.3f'),
              '',
              f'Roll or pitch rate felt beyond the vehicle\'s by more than tilt.rate_limit '
              f'({math.degrees(params.tilt_rate_limit):g} deg/s): {m.tilt_rate_excess} samples '
              f'({100 * m.tilt_rate_excess / max(m.felt_samples, 1):.2f} %), at most '
              f'{math.degrees(m.tilt_rate_peak):.2f} deg/s.', '',
              '## Actuators', '',
              '| leg | peak force (N) | RMS force (N) | peak speed (m/s) | peak power (W) '
              '| stroke reached (m) | stroke used |',
              '|---|---|---|---|---|---|---|']
    for k, label in enumerate(legs.labels):
        lines.append(f'| {label.upper()} | {legs.peak_force[k]:.0f} | {legs.rms_force[k]:.0f} | '
                     f'{legs.peak_speed[k]:.3f} | {legs.peak_power[k]:.0f} | '
                     f'{legs.stroke_min[k]:+.3f} .. {legs.stroke_max[k]:+.3f} | '
                     f'{100 * legs.stroke_used[k]:.0f} % |')
    lines.append(f'| limit | {lim.max_force:.0f} | | {lim.max_speed:g} | | '
                 f'{lim.stroke_min.min():+.3f} .. {lim.stroke_max.max():+.3f} | 100 % |')
    lines += ['', "Solver statuses of the output (the machine's inverse dynamics): "
              + ', '.join(f'{k} {v}' for k, v in legs.statuses.items()) + '.', '',
              '## Limiter', '',
              f'Cue given up in {100 * fraction:.2f} % of samples, {100 * m.given_up_mean:.2f} % '
              f'on average, at most {100 * peak:.0f} %; the limit that made it (samples): '
              f'{_limits_text(limits)}.', '']
    return '\n'.join(lines)


def _thin(n: int) -> slice:
    return slice(None, None, max(1, n // PLOT_POINTS))


def figure(machine: Any, params: CueingParams, result: CueRun, metrics: CueMetrics,
           title: str) -> Any:
    """Felt against vehicle specific force and angular velocity per axis over
    time; each leg's force against speed in its limit box.
    """
    from matplotlib.figure import Figure

    from .plotting import LEG_COLOURS

    fig = Figure(figsize=(13.0, 9.0))
    grid = fig.add_gridspec(3, 3, hspace=0.45, wspace=0.3, left=0.06, right=0.98, top=0.92,
                            bottom=0.06)
    every = _thin(len(result.t))
    t = result.t[every] - result.t[0]
    for row, (felt_v, vehicle, name, unit, scale) in enumerate((
            (metrics.felt_f, result.f, 'specific force', 'm/s²', 1.0),
            (metrics.felt_omega, result.omega, 'angular velocity', 'deg/s', 180 / math.pi))):
        for axis in range(3):
            ax = fig.add_subplot(grid[row, axis])
            ax.plot(t, vehicle[every, axis] * scale, color='0.5', lw=1.0, label='vehicle')
            ax.plot(t, felt_v[every, axis] * scale, color='tab:blue', lw=1.0, label='felt')
            ax.set_title(f'{name} {AXES[axis]} ({unit})', fontsize=9)
            ax.set_xlabel('t (s)', fontsize=8)
            ax.tick_params(labelsize=7)
            if row == 0 and axis == 0:
                ax.legend(fontsize=7, loc='best')
    ax = fig.add_subplot(grid[2, :2])
    legs, lim = metrics.legs, metrics.legs.limits
    for k, label in enumerate(legs.labels):
        ax.plot(legs.speed[:, k], legs.force[:, k], '.', ms=1.5,
                color=LEG_COLOURS[k % len(LEG_COLOURS)], label=label.upper())
    ax.add_patch(_box(lim.max_speed, lim.max_force))
    ax.set_xlabel('leg speed dL/dt (m/s)', fontsize=8)
    ax.set_ylabel('force (N)', fontsize=8)
    ax.set_title('each leg\'s force against speed; the box: its limits', fontsize=9)
    ax.legend(fontsize=7, markerscale=6, ncol=len(legs.labels), loc='lower right')
    ax.tick_params(labelsize=7)
    ax = fig.add_subplot(grid[2, 2])
    ax.plot(t, 100 * np.asarray(result.given_up, dtype=float)[every], color='tab:red', lw=1.0)
    ax.set_title('cue given up by the limiter (%)', fontsize=9)
    ax.set_xlabel('t (s)', fontsize=8)
    ax.tick_params(labelsize=7)
    fig.suptitle(f'{title}: {machine.title}, limiter {params.limiter}', fontsize=11)
    return fig


def _box(speed: float, force: float) -> Any:
    from matplotlib.patches import Rectangle

    return Rectangle((-speed, -force), 2 * speed, 2 * force, fill=False, ec='k', lw=1.2,
                     ls='--')
