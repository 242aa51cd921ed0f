"""``flight-sim-dynamics simulate``: the digital twin on files
(:func:`flight_sim_dynamics.simulate`) for any machine (the plant's parameter
file names it), open loop (``--forces``) or closed loop (``--reference``,
``--motion``); a run that stops writes its rows and exits 1. Column names come
from the plant's machine (:func:`columns`).
"""
from __future__ import annotations

import argparse
import math
import sys
from typing import Callable, NamedTuple, Sequence

import numpy as np

import flight_sim_dynamics as fsd

from ..core.interpolation import ForceHistory, Reference, SampleError
from ..core.machine import Machine
from ..core.servo import DEFAULT_BANDWIDTH_HZ, DEFAULT_DAMPING, Servo
from ..core.simulation import DEFAULT_STEP, step_count
from ..config.machine_files import example_params_file
from ..machines import MACHINES
from ..machines.api import servo_for_bandwidth, simulate
from .csv_io import CsvError, Table, read_table, write_csv
from .columns import per_leg, trajectory_columns
from .main import CliError, load_model, read_trajectory, report_not_ok

#: The most ``simulate`` reads of an input file: its rows are held in memory several times.
MAX_INPUT_BYTES = 64 << 20


class Columns(NamedTuple):
    """A machine's column names in ``simulate``'s files."""

    trajectory: tuple[str, ...]   # t, the pose, its rates (_rate) and accelerations (_acc)
    forces: tuple[str, ...]       # t, force_<leg>: the open loop's input
    output: tuple[str, ...]       # the trajectory, length_<leg>, rate_<leg>, force_<leg>
    errors: tuple[str, ...]       # closed loop: <coordinate>_error, length_error_<leg>


def columns(machine: Machine) -> Columns:
    """The names of ``machine``'s columns in ``simulate``'s files (cli/columns.py)."""
    pose = machine.coordinates
    per_leg_names = [per_leg(machine, field) for field in ('length', 'rate', 'force')]
    trajectory = trajectory_columns(machine)
    return Columns(trajectory, ('t',) + per_leg_names[2], trajectory + sum(per_leg_names, ()),
                   tuple(f'{c}_error' for c in pose) + per_leg(machine, 'length_error'))


#: The default machine's output columns (closed loop adds ERROR_COLUMNS; then ``status``).
OUTPUT_COLUMNS, ERROR_COLUMNS = columns(MACHINES[0])[2:]


def _counts(per: str, size: Callable[[Machine], int], values: list[str]) -> str:
    """How many numbers an option takes, two per leg or coordinate (``per``,
    ``size(machine)`` of them): each machine's count, the default machine's
    ``values`` named.
    """
    return f'two per {per}: ' + ', '.join(
        f'{2 * size(m)} for the {m.title}' + (f" ({' '.join(values)})" if m is MACHINES[0]
                                              else '')
        for m in MACHINES)


def configure(p: argparse.ArgumentParser) -> None:
    default, title = columns(MACHINES[0]), MACHINES[0].title
    source = p.add_mutually_exclusive_group(required=True)
    source.add_argument('--forces', metavar='CSV',
                        help=f'open loop: actuator forces, columns t,force_<leg> ({title}: '
                             + ','.join(default.forces) + "; '-' for standard input; solve's "
                             'output, CSV or .npz, will do)')
    source.add_argument('--reference', metavar='CSV',
                        help='closed loop: a reference motion, the trajectory CSV solve reads '
                             f'({title}: ' + ','.join(default.trajectory) + '; missing rates or '
                             'accelerations estimated as solve does)')
    source.add_argument('--motion', metavar='NAME',
                        help="closed loop: a built-in reference motion of the plant's machine "
                             f"({title}: {', '.join(MACHINES[0].motions)})")
    p.add_argument('-o', '--output', required=True, metavar='CSV',
                   help="simulated motion to write ('-' for standard output): the trajectory, "
                        'length_<leg>, rate_<leg>, force_<leg>, in closed loop '
                        f'<coordinate>_error, length_error_<leg>, then status ({title}: '
                        + ','.join(OUTPUT_COLUMNS + ERROR_COLUMNS) + ',status)')
    p.add_argument('--params', metavar='YAML', default=None,
                   help="the controller's parameter file, and the plant's unless "
                        '--plant-params (default: the packaged parameters; a file naming its '
                        f'machine, e.g. {example_params_file()}, simulates that machine)')
    p.add_argument('--plant-params', metavar='YAML', default=None,
                   help='parameter file of the simulated machine (default: --params)')
    p.add_argument('--plant-scene', metavar='NAME_OR_YAML', default=None,
                   help="effects the simulated machine has (default: the plant file's scene, "
                        'as solve reads it; needs inertia)')
    p.add_argument('--feedforward', metavar='none|NAME_OR_YAML', default=None,
                   help='closed loop: scene of the feed-forward, or none (default: the '
                        'plant scene)')
    gains = p.add_mutually_exclusive_group()
    gains.add_argument('--bandwidth', type=float, default=None, metavar='HZ',
                       help='closed loop: critically damped servo gains of this bandwidth '
                            f'(default {DEFAULT_BANDWIDTH_HZ:g} Hz)')
    gains.add_argument('--gains', type=float, nargs='+', default=None, metavar='GAIN',
                       help='closed loop: PD gains per actuator, kp of each leg (N/m) then kd '
                            'of each leg (N s/m), ' + _counts('leg', lambda m: len(m.legs), [
                                f'{k}_{label.upper()}' for k in ('KP', 'KD')
                                for label in MACHINES[0].leg_labels]))
    p.add_argument('--step', type=float, default=DEFAULT_STEP, metavar='S',
                   help=f'RK4 step, s (default {DEFAULT_STEP:g})')
    p.add_argument('--initial', type=float, nargs='+', default=None, metavar='X',
                   help='initial state: the pose then its rates (m, rad, m/s, rad/s), '
                        + _counts('coordinate', lambda m: m.dof,
                                  [f'{c.upper()}{end}' for end in ('', '_RATE')
                                   for c in MACHINES[0].coordinates])
                        + "; default: rest, or the reference's start")


def _split(option: str, values: list[float] | None, n: int, what: str
           ) -> tuple[list[float], list[float]] | None:
    """``values`` as two halves of ``n`` numbers each; CliError for another count."""
    if values is None:
        return None
    if len(values) != 2 * n:
        raise CliError(f'{option}: expected {2 * n} numbers ({what}), got {len(values)}')
    return values[:n], values[n:]


def located(exc: SampleError, table: Table, columns: Sequence[str]) -> CsvError:
    """The error of a bad sample of ``table`` (its ``columns`` in the order of the
    sample's, after ``t``) at its file, line and column; a value estimated from
    the file's (a rate from the poses) blames the value the file gives.
    """
    name = 't' if exc.column is None else columns[exc.column]
    # <c>_acc is estimated from <c>_rate, <c>_rate from <c>: the first the file gives
    base = name.removesuffix('_acc').removesuffix('_rate')
    source = next((c for c in (name, base + '_rate', base)
                   if c in table.names and c not in table.estimated), name)
    row = exc.row
    if source != name:                      # the largest of the rows the estimate used
        lo = max(0, row - 2)
        row = lo + int(np.argmax(np.abs(table[source][lo:row + 1])))
        reason = f'is too large: the {name} estimated from it is not finite'
    else:
        reason = exc.reason
    value = float(table[source][row])
    return CsvError(f'{source} = {value!r} {reason}', path=table.path,
                    line=int(table.lines[row]), name=source)


def check_duration(table: Table, step: float) -> None:
    """CsvError at the last row when the file's times need too many steps of
    ``step`` (a valid step: else the simulation names it).
    """
    if math.isfinite(step) and step > 0:
        try:
            step_count(float(table['t'][0]), float(table['t'][-1]), step)
        except ValueError as exc:
            raise CsvError(f"t = {float(table['t'][-1])!r}: {exc}", path=table.path,
                           line=int(table.lines[-1]), name='t') from None


def _reference(args: argparse.Namespace, plant, machine: Machine, names: Columns) -> Reference:
    if args.reference is not None:
        table = read_trajectory(args.reference, plant, limit=MAX_INPUT_BYTES,
                                params=args.plant_params if args.plant_params is not None
                                else args.params)
        dof = machine.dof
        groups = [names.trajectory[k:k + dof] for k in (1, 1 + dof, 1 + 2 * dof)]
        cols = [np.column_stack([table[n] for n in group]) for group in groups]
        try:
            reference = Reference.from_samples(table['t'], *cols, dof=dof)
        except SampleError as exc:
            group = {'q': 0, 'qd': 1, 'qdd': 2}.get(exc.name, 0)
            raise located(exc, table, groups[group]) from None
        check_duration(table, args.step)
        return reference
    motion = machine.motions.get(args.motion)
    if motion is None:
        choices = ', '.join(repr(m) for m in machine.motions)
        raise CliError(f'--motion: invalid choice: {args.motion!r} ' + (
            f"(choose from {choices}: the built-in motions of machine '{machine.name}')"
            if choices else f"(machine '{machine.name}' has no built-in motion)"))
    return Reference.from_motion(motion)


def run(args: argparse.Namespace) -> int:
    """The ``simulate`` subcommand; 0 when the run reached its end, 1 when it stopped."""
    given = [name for name, value in (('--feedforward', args.feedforward),
                                      ('--bandwidth', args.bandwidth), ('--gains', args.gains))
             if value is not None]
    if args.forces is not None and given:
        raise ValueError(f"{', '.join(given)}: closed loop only (--reference or --motion), "
                         'not with --forces')
    plant_params = args.plant_params if args.plant_params is not None else args.params
    plant = load_model(plant_params, args.plant_scene,
                       '--plant-params' if args.plant_params else '--params', '--plant-scene',
                       machines=MACHINES)
    machine = fsd.machine_of(plant)
    names = columns(machine)
    initial = _split('--initial', args.initial, machine.dof,
                     f"{', '.join(machine.coordinates)} and their rates")
    gains = _split('--gains', args.gains, len(machine.legs), 'kp then kd of each leg')
    if args.forces is not None:
        table = read_table(args.forces, required=names.forces, limit=MAX_INPUT_BYTES)
        try:
            forces = ForceHistory(table['t'], np.column_stack([table[n] for n in
                                                               names.forces[1:]]),
                                  len(machine.legs))
        except SampleError as exc:
            raise located(exc, table, names.forces[1:]) from None
        check_duration(table, args.step)
        sim = simulate(plant, forces=forces, initial=initial, step=args.step)
    else:
        reference = _reference(args, plant, machine, names)
        scene = args.feedforward if args.feedforward is not None else plant.scene
        feedforward = None if scene == 'none' else load_model(
            args.params, scene, scene_option='--feedforward', machines=MACHINES)
        hz = DEFAULT_BANDWIDTH_HZ if args.bandwidth is None else args.bandwidth
        servo = (Servo(tuple(gains[0]), tuple(gains[1])) if gains is not None
                 else servo_for_bandwidth(plant, hz, DEFAULT_DAMPING))
        sim = simulate(plant, reference=reference, feedforward=feedforward,
                       servo=servo, initial=initial, step=args.step)
    data = [sim.t, sim.q, sim.qd, sim.qdd, sim.length, sim.rate, sim.force]
    header = names.output
    if sim.pose_error is not None:
        data += [sim.pose_error, sim.length_error]
        header += names.errors
    write_csv(args.output, header, np.column_stack(data),
              text=('status', [str(s) for s in sim.status]))
    summary = (f"simulate: plant scene '{plant.scene}', {len(sim.t)} rows, t = {sim.t[0]:g} to "
               f'{sim.t[-1]:g} s, {sim.outcome}')
    if sim.pose_error is not None:
        e = sim.tracking()
        summary += '; tracking error max (RMS): ' + ', '.join(
            f"{n} {e[n + '_max']:.3g} ({e[n + '_rms']:.3g}) {unit}"
            for n, unit in zip(machine.coordinates + ('length',), machine.units + ('m',)))
    print(summary, file=sys.stderr if args.output == '-' else sys.stdout)
    report_not_ok('', sim.status, sim.detail, lambda i: f't = {sim.t[i]:.6g} s')
    if sim.outcome != fsd.Status.OK:
        print(f'warning: simulation stopped: {sim.outcome}: {sim.outcome_detail}; '
              f'{len(sim.t)} rows written', file=sys.stderr)
        return 1
    return 0
