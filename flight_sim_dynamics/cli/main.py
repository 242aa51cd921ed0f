"""Command line: ``flight-sim-dynamics COMMAND`` (``--help`` lists them; ``node``,
``sim``, ``demo-planner`` and ``demo`` are handed to their module). Every error
is exit status 2, one line ``error: ...`` on standard error, no partial output
(a file is written whole or not at all; ``solve -o -`` streams its rows).
"""
from __future__ import annotations

import argparse
import contextlib
import dataclasses
import importlib
import itertools
import math
import os
import sys
from collections import Counter
from typing import Any, Callable, Iterable, Iterator, Sequence

import numpy as np

import flight_sim_dynamics as fsd

from . import csv_io
from ..config.errors import shorten
from ..config.machine_files import load_model_noting, load_node_values
from ..config.scenes import SceneError
from ..core.estimator import DerivativeEstimator, estimate_rows
from ..core.machine import Machine
from ..core.motion import Motion
from ..machines import MACHINES
from ..machines.api import poses_along
from .columns import (DEFAULT_MACHINE, PER_LEG_FIELDS, acceleration_columns, joint_columns,
                      output_columns, per_leg, rate_columns, trajectory_columns)
# the default machine's columns, as the commands' modules and tests name them
from .columns import JOINT_COLUMNS, LENGTH_COLUMNS, OUTPUT_COLUMNS, PLOT_COLUMNS  # noqa: F401
from .csv_io import CsvError

PROG = 'flight-sim-dynamics'
DEFAULT_RATE_HZ = 100.0
MAX_SAMPLES = 10_000_000
#: The default machine's leg labels.
LEGS = DEFAULT_MACHINE.leg_labels


class CliError(Exception):
    """A user error: printed as ``error: <message>``, exit status 2."""


def load_model(params: str | None, scene: str | None = None, option: str = '--params',
               scene_option: str = '--scene', *,
               machines: Sequence[Machine] = (DEFAULT_MACHINE,), show_notes: bool = True) -> Any:
    """The model of ``--params`` and ``--scene``, of one of the ``machines`` a
    command serves; a CliError names the option at fault, a note (unless not
    ``show_notes``: a command that sets the scenes itself) the file's values of
    an effect the scene leaves off.
    """
    if params is not None and not os.path.isfile(params):
        raise CliError(f"{option} {params}: no such file")
    try:
        model, notes = load_model_noting(params, scene=scene)
    except SceneError as exc:           # before its parent class ParameterError
        raise CliError(f'{scene_option}: {exc}') from None
    except fsd.ParameterError as exc:
        raise CliError(f"{option} {params or '(packaged defaults)'}: {exc}") from None
    machine = fsd.machine_of(model)
    if not any(machine is m for m in machines):
        raise CliError(f"{option} {params or '(packaged defaults)'}: the {machine.title} "
                       f"('{machine.name}'): this command serves the "
                       + ' and the '.join(m.title for m in machines))
    for note in notes if show_notes else ():
        print(f'note: {option} {note}', file=sys.stderr)
    return model


class _Parser(argparse.ArgumentParser):
    """argparse, but usage errors are one line ``error: ...`` and exit 2."""

    def error(self, message: str):  # type: ignore[override]
        self.exit(2, f"error: {message} (see '{self.prog} --help')\n")


def _motions_help() -> str:
    return '; '.join(f"the {m.title}'s {', '.join(m.examples)}" for m in MACHINES)


def _params_option(p: argparse.ArgumentParser) -> None:
    p.add_argument('--params', metavar='YAML', default=None,
                   help='parameter file (ROS 2 format), which names the machine; default: the '
                        f'packaged parameters of the {DEFAULT_MACHINE.title}')


def _configure_example(p: argparse.ArgumentParser) -> None:
    p.add_argument('name', metavar='MOTION',
                   help='a built-in motion of the machine of --params: ' + _motions_help())
    p.add_argument('--rate', type=float, default=DEFAULT_RATE_HZ, metavar='HZ',
                   help=f'sampling rate in Hz (default {DEFAULT_RATE_HZ:g}); samples '
                        "t = 0, 1/HZ, ... up to the motion's duration")
    p.add_argument('-o', '--output', required=True, metavar='CSV',
                   help="trajectory CSV to write ('-' for standard output); columns "
                        't, the coordinates, their <coordinate>_rate and <coordinate>_acc: '
                        + ','.join(trajectory_columns(DEFAULT_MACHINE)) + ' for the '
                        + DEFAULT_MACHINE.title)
    _params_option(p)


def example_motion(machine: Machine, name: str) -> Motion:
    """The motion ``name`` that ``example`` offers for ``machine``, or a CliError."""
    if name not in machine.examples:
        raise CliError(f"unknown motion '{name}' of the {machine.title}; choose one of "
                       + ', '.join(machine.examples))
    return machine.motions[name]


def cmd_example(args: argparse.Namespace) -> int:
    rate = args.rate
    if not (math.isfinite(rate) and rate > 0):
        raise CliError(f'--rate must be a positive number of Hz, got {rate:g}')
    machine = fsd.machine_of(load_model(args.params, machines=MACHINES))
    motion = example_motion(machine, args.name)
    if motion.duration * rate + 1 > MAX_SAMPLES:
        raise CliError(f'--rate {rate:g} Hz gives more than {MAX_SAMPLES} samples over '
                       f'{motion.duration:g} s')
    t, q, qd, qdd = motion.sampled(rate)
    csv_io.write_csv(args.output, trajectory_columns(machine), np.column_stack([t, q, qd, qdd]))
    return 0


def _configure_solve(p: argparse.ArgumentParser) -> None:
    p.add_argument('input', metavar='TRAJ_CSV',
                   help="trajectory CSV ('-' for standard input): t, the machine's coordinates, "
                        '<coordinate>_rate and <coordinate>_acc in any order (SI units), e.g. '
                        + ', '.join(f"the {m.title}'s " + ','.join(trajectory_columns(m))
                                    for m in MACHINES)
                        + '; missing rates or accelerations are estimated from the poses as '
                        'the node does')
    p.add_argument('-o', '--output', required=True, metavar='CSV_OR_NPZ',
                   help="results to write ('-' for standard output: the rows as they are "
                        f'solved, {SOLVE_BLOCK_ROWS:,} at a time, an error part way leaving '
                        'those before it): '
                        + '; '.join(f"the {m.title}'s " + ','.join(output_columns(m))
                                    + ',status' for m in MACHINES)
                        + '; a name ending in .npz writes numpy\'s .npz (a float64 array per '
                        'column, status as strings, names)')
    _params_option(p)
    p.add_argument('--scene', metavar='NAME_OR_YAML', default=None,
                   help='effects to simulate: a scene of config/scenes or a scene file '
                        '(default full: every weight, inertia and velocity product; no payload, no '
                        'friction)')
    p.add_argument('--cond', action='store_true',
                   help='also write the costly fields of the machines that have them (an SVD '
                        'per row): '
                        + '; '.join(f"the {m.title}'s {', '.join(m.costly_fields)}"
                                    for m in MACHINES if m.costly_fields)
                        + " (another machine's condition figures are always written)")
    p.add_argument('--joints', action='store_true',
                   help="also write the machine's joint variables ("
                        + ', '.join(f'{len(m.joints)} for the {m.title}' for m in MACHINES)
                        + '), their rates (<name>_rate) and accelerations (<name>_acc)')


def solve_table(model, table: csv_io.Table, *, joints: bool = False, exact_cond: bool = False,
                not_ok: NotOk | None = None) -> tuple[tuple[str, ...], np.ndarray, list[str]]:
    """Solve every row of a trajectory table: (column names, data, statuses);
    ``exact_cond``: the machine's costly fields too (:attr:`Machine.costly_fields`).
    The rows that are not ok are counted in ``not_ok`` (None: reported now).
    """
    machine = fsd.machine_of(model)
    data, n = table.data, len(table.data)
    sol = fsd.solve_batch(model, *(data[:, [table.names.index(c) for c in group]] for group in (
        machine.coordinates, rate_columns(machine), acceleration_columns(machine))))
    counted = NotOk() if not_ok is None else not_ok
    counted.add(sol.status, sol.detail, lambda i: f'line {int(table.lines[i])}')
    if not_ok is None:
        counted.report(f'{table.path}: ')
    columns = [table['t']] + [np.asarray(getattr(sol, field), dtype=float).reshape(n, -1)
                              for field in PER_LEG_FIELDS + machine.sample_fields]
    names = output_columns(machine)
    if exact_cond:                      # e.g. an SVD per row: ~40 us each, so on request
        columns += [np.asarray(getattr(sol, field), dtype=float).reshape(n)
                    for field in machine.costly_fields]
        names = names + machine.costly_fields
    if joints:
        columns += [np.asarray(getattr(sol, field), dtype=float).reshape(n, -1)
                    for field in ('joints', 'joint_rates', 'joint_accelerations')]
        names = names + joint_columns(machine)
    return names, np.column_stack(columns), [str(s) for s in sol.status]


class NotOk:
    """The rows that are not ok, counted over one table or many (blocks of a file)."""

    def __init__(self) -> None:
        self.counts: Counter[str] = Counter()
        self.rows = 0
        self.first: tuple[str, object, object] | None = None

    def add(self, status: Sequence, detail: Sequence, where: Callable[[int], str]) -> None:
        """Count the rows of ``status``, the first not ok placed by ``where``."""
        words = [str(s) for s in status]
        bad = [i for i, w in enumerate(words) if w != 'ok']
        self.rows += len(words)
        self.counts.update(words[i] for i in bad)
        if bad and self.first is None:
            self.first = (where(bad[0]), status[bad[0]], detail[bad[0]])

    def report(self, prefix: str) -> None:
        """Summarise them on standard error (nothing if every row is ok)."""
        if self.first is not None:
            summary = ', '.join(f'{n} {w}' for w, n in sorted(self.counts.items()))
            where, status, detail = self.first
            print(f'warning: {prefix}{sum(self.counts.values())} of {self.rows} rows are not ok '
                  f'({summary}); first at {where}: {status}: {detail}', file=sys.stderr)


def report_not_ok(prefix: str, status: Sequence, detail: Sequence,
                  where: Callable[[int], str]) -> None:
    """Summarise the rows that are not ok on standard error, the first placed by ``where``."""
    counted = NotOk()
    counted.add(status, detail, where)
    counted.report(prefix)


def other_machine(names: Iterable[str], machine: Machine,
                  columns: Callable[[Machine], Sequence[str]]) -> Machine | None:
    """The machine a table is for, told by its header ``names``, when it is not
    ``machine``: the one whose ``columns`` (e.g. its pose coordinates, its
    ``length_<leg>``) the header holds exactly, among every machine's.
    """
    given = set(names) & {c for m in MACHINES for c in columns(m)}
    if given == set(columns(machine)):
        return None
    return next((m for m in MACHINES if set(columns(m)) == given), None)


def refuse_other_machine(names: Iterable[str], machine: Machine,
                         columns: Callable[[Machine], Sequence[str]], what: str,
                         path: str) -> None:
    """CsvError (line 1) when the header ``names`` is ``what`` (e.g. 'a
    trajectory') of a machine other than ``machine`` (:func:`other_machine`),
    saying how to give that machine.
    """
    other = other_machine(names, machine, columns)
    if other is None:
        return
    how = ("give its parameter file with --params (packaged: "
           + ', '.join(f'config/{name}.yaml' for name in other.parameter_files) + ')'
           if other.parameter_files else
           f'leave --params out (the packaged {other.title}) or give one of its files')
    raise CsvError(f"{what} of the {other.title} ({', '.join(columns(other))}), but the "
                   f'parameters (--params) describe the {machine.title}, whose columns are '
                   f"{','.join(columns(machine))}: {how}", path=path, line=1)


def read_trajectory(path: str | os.PathLike[str], model: Any, limit: int | None = None,
                    params: str | None = None) -> csv_io.Table:
    """The trajectory table of ``path`` (at most ``limit`` bytes), as one
    table (:func:`trajectory_tables`; ``params``: the model's parameter file).
    """
    table, = trajectory_tables(path, model, limit, params=params)   # (its warnings at its end)
    return table


def estimator_settings(params: str | None) -> tuple[str, float]:
    """The estimator's ``estimator.method`` and ``estimator.max_gap`` of the
    parameter file ``params`` of any machine (None: the packaged defaults), as
    the node reads them (:func:`.config.machine_files.load_node_values`).
    """
    try:
        values = load_node_values(params)
    except fsd.ParameterError as exc:
        raise CliError(f"--params {params or '(packaged defaults)'}: {exc}") from None
    return values['estimator.method'], values['estimator.max_gap']


def trajectory_tables(path: str | os.PathLike[str], model: Any, limit: int | None = None,
                      rows: int | None = None, params: str | None = None
                      ) -> Iterator[csv_io.Table]:
    """The trajectory of ``path`` (at most ``limit`` bytes) for the model's
    machine, in tables of at most ``rows`` rows (None: one), rates or
    accelerations it lacks estimated from the poses as the node does, with the
    estimator settings of the model's parameter file ``params`` (a note;
    the estimate runs on across the tables). Another machine's trajectory is a
    CsvError.
    """
    machine = fsd.machine_of(model)
    pose, rate_names, acc_names = (machine.coordinates, rate_columns(machine),
                                   acceleration_columns(machine))
    with csv_io.CsvReader.open(path, limit) as reader:
        named = set(reader.names)
        refuse_other_machine(named, machine, lambda m: m.coordinates, 'a trajectory',
                             reader.path)
        rates, accelerations = (any(n in named for n in group)
                                for group in (rate_names, acc_names))
        required = (('t',) + pose + (rate_names if rates else ())
                    + (acc_names if accelerations else ()))
        tables = reader.tables(required=required, skip_extra=True, rows=rows)
        first = next(tables)
        if first.skipped:
            print(f"note: {first.path}: ignoring column{'s' if len(first.skipped) > 1 else ''} "
                  f"{', '.join(repr(n) for n in first.skipped)}; a trajectory has "
                  + ','.join(trajectory_columns(machine)), file=sys.stderr)
        if rates and accelerations:
            yield first
            yield from tables
            return
        # the file's settings, for any machine
        method, gap = estimator_settings(params)
        what = ' and '.join(w for w, given in (('rates', rates),
                                                ('accelerations', accelerations)) if not given)
        print(f'note: {first.path}: no {what} columns: estimated from the poses as the node '
              f'does ({method} backward differences, causal; the first rows start from '
              'rest)', file=sys.stderr)
        estimator = DerivativeEstimator(method, gap, angles=machine.angles)
        restarts, first_restart, last_t = 0, None, None
        for table in itertools.chain([first], tables):
            t, q = table['t'], table.data[:, [table.names.index(n) for n in pose]]
            qd_in = table.data[:, [table.names.index(n) for n in rate_names]] if rates else None
            qd, qdd = estimate_rows(t, q, qd_in, estimator=estimator)
            added = [(names, v) for names, v, given in ((rate_names, qd, rates),
                                                        (acc_names, qdd, accelerations))
                     if not given]
            steps = np.diff(t if last_t is None else np.concatenate([[last_t], t]))
            restart = ~((steps > 0.0) & (steps <= gap))
            if restart.any() and first_restart is None:
                first_restart = int(table.lines[int(np.argmax(restart))
                                                + (1 if last_t is None else 0)])
            restarts += int(restart.sum())
            last_t = float(t[-1])
            yield dataclasses.replace(
                table, names=table.names + sum((n for n, _ in added), ()),
                data=np.column_stack([table.data] + [v for _, v in added]),
                estimated=sum((n for n, _ in added), ()))
        if restarts:
            print(f'warning: {first.path}: the estimate starts again from rest at '
                  f'{restarts} row(s), first line {first_restart}: t does not increase, or '
                  f'steps by more than estimator.max_gap = {gap:g} s', file=sys.stderr)


#: Rows ``solve`` reads, solves and writes at a time: its memory does not grow with the file.
SOLVE_BLOCK_ROWS = 65536


def cmd_solve(args: argparse.Namespace) -> int:
    model = load_model(args.params, args.scene, machines=MACHINES)
    machine = fsd.machine_of(model)
    if args.cond and not machine.costly_fields:
        raise CliError(f'--cond: the {machine.title} has no condition number beyond '
                       f"{', '.join(machine.sample_fields)}, which solve always writes")
    tables = trajectory_tables(args.input, model, rows=SOLVE_BLOCK_ROWS, params=args.params)
    first = next(tables)        # a bad header: an error before any output
    not_ok = NotOk()
    names, data, status = solve_table(model, first, joints=args.joints, exact_cond=args.cond,
                                      not_ok=not_ok)
    with csv_io.table_writer(args.output, names, 'status') as write:
        write(data, status)
        del data, status
        for table in tables:
            write(*solve_table(model, table, joints=args.joints, exact_cond=args.cond,
                               not_ok=not_ok)[1:])
    not_ok.report(f'{first.path}: ')
    return 0


def _configure_forward(p: argparse.ArgumentParser) -> None:
    p.add_argument('lengths', nargs='*', type=float, metavar='L',
                   help='one leg length per leg (m, joint centre to joint centre): '
                        + '; '.join(f"the {m.title}'s "
                                    + ' '.join(f'L_{label.upper()}' for label in m.leg_labels)
                                    for m in MACHINES))
    p.add_argument('--csv', metavar='CSV', default=None,
                   help="instead: a CSV with the machine's length_<leg> columns (and t), e.g. "
                        "solve's output; writes [t,] the coordinates and status to -o")
    p.add_argument('-o', '--output', metavar='CSV', default=None,
                   help="output CSV for --csv ('-' for standard output)")
    _params_option(p)


def number_word(n: int) -> str:
    """``n`` in words where a sentence reads better so ('three', 'six')."""
    return {3: 'three', 6: 'six'}.get(n, str(n))


def cmd_forward(args: argparse.Namespace) -> int:
    """Pose from measured leg lengths (safeguarded Newton, the machine's forward_kinematics)."""
    model = load_model(args.params, machines=MACHINES)
    machine = fsd.machine_of(model)
    if args.csv is None:
        legs = len(machine.leg_labels)
        if len(args.lengths) != legs:
            raise CliError(f'expected {number_word(legs)} leg lengths '
                           + ' '.join(f'L_{label.upper()}' for label in machine.leg_labels)
                           + f', got {len(args.lengths)}')
        result = fsd.forward_kinematics(model, args.lengths)
        pose = ' '.join(f'{c}={float(v)!r}' for c, v in zip(machine.coordinates, result.pose))
        print(f'{pose} status={result.status} '
              f'residual={result.residual:.3g} iterations={result.iterations}'
              + (f' detail={result.detail!r}' if result.detail else ''))
        return 0 if result.status == fsd.Status.OK else 1
    if args.lengths or args.output is None:
        raise CliError('--csv takes no lengths on the command line, and needs -o OUTPUT')
    lengths = per_leg(machine, 'length')
    table = csv_io.read_csv(args.csv, required=(), allow_extra=True, text_columns=('status',))
    refuse_other_machine(table.names, machine, lambda m: per_leg(m, 'length'),
                         'leg lengths', table.path)
    csv_io.require_columns(table.names, lengths, table.path)
    results = poses_along(model, np.column_stack([table[n] for n in lengths]))
    status = [str(r.status) for r in results]
    extra = ['t'] if 't' in table.names else []
    data = np.column_stack([table[n] for n in extra] + [np.array([r.pose for r in results])])
    csv_io.write_csv(args.output, tuple(extra) + machine.coordinates, data,
                     text=('status', status))
    bad = sum(s != 'ok' for s in status)
    if bad:
        print(f'warning: {table.path}: {bad} of {len(status)} rows have no pose '
              '(status column)', file=sys.stderr)
    return 0


#: Subcommands handed to their module, imported only when used (no rclpy needed otherwise).
FORWARDED: dict[str, tuple[str, str]] = {
    'node': ('flight_sim_dynamics.ros.node', 'run the ROS 2 inverse-dynamics node '
             '(e.g. node --ros-args --params-file FILE)'),
    'sim': ('flight_sim_dynamics.ros.sim_node', 'run the ROS 2 digital twin node platform_sim '
            '(e.g. sim --ros-args -r actuator_commands:=actuator_states)'),
    'demo-planner': ('flight_sim_dynamics.ros.planner', 'run the demo set-point planner node'),
    'demo': ('flight_sim_dynamics.cli.demo', 'run the end-to-end ROS 2 demo'),
}


def forward(command: str, argv: Sequence[str]) -> int:
    module_name, _ = FORWARDED[command]
    try:
        module = importlib.import_module(module_name)
    except ImportError as exc:
        missing = getattr(exc, 'name', None)
        if needs_plot_extra(exc):
            raise CliError(plot_extra_message(command)) from None
        if missing == module_name:
            raise CliError(f"'{command}' is not available in this installation "
                           f'(no module {module_name})') from None
        raise CliError(f"'{command}' needs {missing or 'a module'} (ROS 2 Python packages), "
                       f'which cannot be imported: {exc}') from None
    try:
        rc = module.main(list(argv))
    except SystemExit as exc:           # e.g. its own --help or usage error
        if exc.code is None or isinstance(exc.code, int):
            return exc.code or 0
        print(exc.code, file=sys.stderr)
        return 1
    except Exception as exc:  # noqa: BLE001 - the module's own error: one line, exit 2
        if needs_plot_extra(exc):
            raise CliError(plot_extra_message(command)) from None
        if os.environ.get('FLIGHT_SIM_DYNAMICS_DEBUG'):
            raise
        raise CliError(f'{command}: {type(exc).__name__}: {exc}') from None
    return rc if isinstance(rc, int) else 0


def needs_plot_extra(exc: BaseException) -> bool:
    """Whether ``exc`` is matplotlib (the optional extra ``plot``) missing."""
    name = getattr(exc, 'name', None) or ''
    return isinstance(exc, ImportError) and name.split('.')[0] == 'matplotlib'


def plot_extra_message(command: str) -> str:
    """The one-line error of a subcommand run without matplotlib."""
    return f"{command} needs matplotlib: pip install 'flight_sim_dynamics[plot]'"


def _lazy(module: str) -> tuple[Callable[[argparse.ArgumentParser], None],
                                 Callable[[argparse.Namespace], int]]:
    """configure/run of a subcommand module, imported only when it is used."""
    return (lambda p: importlib.import_module(module).configure(p),
            lambda args: importlib.import_module(module).run(args))


#: name -> (help, configure(parser), handler(args) -> exit status).
SUBCOMMANDS: dict[str, tuple[str, Callable[[argparse.ArgumentParser], None],
                             Callable[[argparse.Namespace], int]]] = {
    'example': ('write a built-in motion of the machine as a trajectory CSV',
                _configure_example, cmd_example),
    'solve': ('inverse dynamics of every row of a trajectory CSV',
              _configure_solve, cmd_solve),
    'plot': ('plot actuator forces and powers against time',
             *_lazy('flight_sim_dynamics.cli.plotting')),
    'forward': ('forward kinematics: the pose from the leg lengths',
                _configure_forward, cmd_forward),
    'bench': ('time per cycle against force error for every scene and single-effect variant, '
              'and the cost of estimating missing accelerations (writes scenes.md, scenes.png)',
              *_lazy('flight_sim_dynamics.cli.bench')),
    'workspace': ('map where the machine (--params) reaches at rest: ranges through home and '
                  'maps coloured by its condition figure, with what bounds them',
                  *_lazy('flight_sim_dynamics.cli.workspace')),
    'animate': ('the mechanism following a solved trajectory (side and front views, actuator '
                'forces as bars, the status of each frame) as .gif, .mp4 (needs ffmpeg) or a '
                '.png still', *_lazy('flight_sim_dynamics.cli.animate')),
    'simulate': ('digital twin: the motion that actuator forces produce (open loop), or that '
                 'servos with a feed-forward scene make of a reference motion (closed loop)',
                 *_lazy('flight_sim_dynamics.cli.simulate')),
    'cue': ('motion cueing: a vehicle log (specific force, angular velocity) through the '
            "washout and the limiter of --params' cueing group into the machine's trajectory "
            'CSV, with a cue report and figure on request', *_lazy('flight_sim_dynamics.cli.cue')),
}


def build_parser(only: str | None = None) -> argparse.ArgumentParser:
    """The command-line parser; ``only``: configure just that subcommand (no
    import of the others' modules).
    """
    example = next(iter(MACHINES[0].examples or MACHINES[0].motions), 'MOTION')
    parser = _Parser(
        prog=PROG,
        description='Inverse dynamics of parallel motion simulators: the '
                    + ' and the '.join(m.title for m in MACHINES)
                    + ' (--params names the machine).',
        epilog=f'Example: {PROG} example {example} -o {example}.csv && '
               f'{PROG} solve {example}.csv -o out.csv && {PROG} plot out.csv -o fig.png. '
               'Errors: exit status 2 and one line "error: ..." on standard error.')
    parser.add_argument('--version', action='version', version=f'%(prog)s {fsd.__version__}')
    sub = parser.add_subparsers(dest='command', metavar='COMMAND', parser_class=_Parser)
    for name, (help_text, configure, handler) in SUBCOMMANDS.items():
        p = sub.add_parser(name, help=help_text, description=help_text[:1].upper() + help_text[1:])
        if only is None or name == only:
            configure(p)
            p.set_defaults(handler=handler)
    for name, (_, help_text) in FORWARDED.items():
        # Listed for --help only: main() forwards these before argparse runs.
        sub.add_parser(name, help=help_text + ' (options are passed through)', add_help=False)
    return parser


#: The options that name a file a command reads.
INPUT_OPTIONS = ('input', 'csv', 'forces', 'reference', 'params', 'plant_params')


def refuse_replacing_an_input(args: argparse.Namespace) -> None:
    """CliError when ``-o`` names a file the command reads (os.path.samefile:
    links and other spellings too): it would be replaced before it is read.
    """
    output = getattr(args, 'output', None)
    for name in INPUT_OPTIONS:
        given = getattr(args, name, None)
        if isinstance(given, str) and isinstance(output, str) and '-' not in (given, output):
            with contextlib.suppress(OSError):      # either does not exist yet: not the same
                if os.path.samefile(given, output):
                    raise CliError(f'-o {output} is the input {given}: it would be replaced; '
                                   'write to another file')


def _one_line(message: object) -> str:
    """``message`` on one line, each huge word (an echoed value) cut (:func:`shorten`)."""
    return shorten(' '.join(str(message).split()))


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; returns the exit status (0 ok, 2 error)."""
    argv = list(sys.argv[1:] if argv is None else argv)
    try:
        if argv and argv[0] in FORWARDED:
            return forward(argv[0], argv[1:])
        parser = build_parser(argv[0] if argv and argv[0] in SUBCOMMANDS else None)
        try:
            args = parser.parse_args(argv)
        except SystemExit as exc:       # --help (0) or a usage error (2, already printed)
            return exc.code if isinstance(exc.code, int) else 2
        if args.command is None:
            parser.print_help(sys.stderr)
            return 2
        args.argv = argv[1:]            # the options as given (workspace's markdown names them)
        refuse_replacing_an_input(args)
        return args.handler(args)
    except KeyboardInterrupt:
        print('error: interrupted', file=sys.stderr)
        return 130
    except BrokenPipeError:
        # e.g. `... -o - | head`: the reader went away; not an error of ours
        with contextlib.suppress(OSError):
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0
    except (CliError, CsvError, ValueError, OSError) as exc:
        # ValueError covers ParameterError, UnreachablePoseError
        where = isinstance(exc, OSError) and exc.filename is not None
        message = f"'{exc.filename}': {exc.strerror or exc}" if where else exc
        print(f'error: {_one_line(message)}', file=sys.stderr)
        return 2
    except Exception as exc:  # noqa: BLE001 - a bug: still one line, unless debugging
        if needs_plot_extra(exc):       # plot, bench, workspace without the extra
            print(f'error: {plot_extra_message(argv[0])}', file=sys.stderr)
            return 2
        if os.environ.get('FLIGHT_SIM_DYNAMICS_DEBUG'):
            raise
        print(f'error: internal error ({type(exc).__name__}: {_one_line(exc)}); '
              'set FLIGHT_SIM_DYNAMICS_DEBUG=1 for a traceback', file=sys.stderr)
        return 2


if __name__ == '__main__':  # pragma: no cover
    sys.exit(main())
