"""``flight-sim-dynamics simulate``: the digital twin on files
(:func:`flight_sim_dynamics.simulate`), open loop (``--forces``) or closed loop
(``--reference``, ``--motion``); a run that stops writes its rows and exits 1.
"""
from __future__ import annotations

import argparse
import sys

import numpy as np

import flight_sim_dynamics as fsd

from ..core.interpolation import ForceHistory, Reference
from ..core.servo import DEFAULT_BANDWIDTH_HZ, DEFAULT_DAMPING, Servo
from ..core.simulation import DEFAULT_STEP
from ..machines.api import servo_for_bandwidth, simulate
from ..machines.staicu.motions import MOTIONS
from .csv_io import TRAJECTORY_COLUMNS, read_table, write_csv
from .main import LEGS, load_model, read_trajectory, report_not_ok

FORCE_COLUMNS = ('t',) + tuple(f'force_{leg}' for leg in LEGS)
POSE = ('surge', 'heave', 'roll')
#: Output columns, in order (closed loop adds ERROR_COLUMNS; then ``status``).
OUTPUT_COLUMNS = (TRAJECTORY_COLUMNS + tuple(f'length_{leg}' for leg in LEGS)
                  + tuple(f'rate_{leg}' for leg in LEGS) + tuple(f'force_{leg}' for leg in LEGS))
ERROR_COLUMNS = (tuple(f'{name}_error' for name in POSE)
                 + tuple(f'length_error_{leg}' for leg in LEGS))
#: The most ``simulate`` reads of an input file: its rows are held in memory several times.
MAX_INPUT_BYTES = 64 << 20


def configure(p: argparse.ArgumentParser) -> None:
    source = p.add_mutually_exclusive_group(required=True)
    source.add_argument('--forces', metavar='CSV',
                        help='open loop: actuator forces, columns ' + ','.join(FORCE_COLUMNS)
                             + " ('-' for standard input; solve's output, CSV or .npz, will do)")
    source.add_argument('--reference', metavar='CSV',
                        help='closed loop: a reference motion, the trajectory CSV solve reads ('
                             + ','.join(TRAJECTORY_COLUMNS) + '; missing rates or accelerations '
                             'estimated as solve does)')
    source.add_argument('--motion', choices=tuple(MOTIONS),
                        help='closed loop: a built-in reference motion')
    p.add_argument('-o', '--output', required=True, metavar='CSV',
                   help="simulated motion to write ('-' for standard output): "
                        + ','.join(OUTPUT_COLUMNS) + ', in closed loop '
                        + ','.join(ERROR_COLUMNS) + ', then status')
    p.add_argument('--params', metavar='YAML', default=None,
                   help="the controller's parameter file, and the plant's unless "
                        '--plant-params (default: the packaged parameters)')
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
    gains.add_argument('--gains', type=float, nargs=6, default=None,
                       metavar=('KP_A', 'KP_B', 'KP_C', 'KD_A', 'KD_B', 'KD_C'),
                       help='closed loop: PD gains per actuator, N/m and N s/m')
    p.add_argument('--step', type=float, default=DEFAULT_STEP, metavar='S',
                   help=f'RK4 step, s (default {DEFAULT_STEP:g})')
    p.add_argument('--initial', type=float, nargs=6, default=None,
                   metavar=('SURGE', 'HEAVE', 'ROLL', 'SURGE_RATE', 'HEAVE_RATE', 'ROLL_RATE'),
                   help="initial state (m, rad, m/s, rad/s); default: rest, or the reference's "
                        'start')


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
                       '--plant-params' if args.plant_params else '--params', '--plant-scene')
    initial = None if args.initial is None else (args.initial[:3], args.initial[3:])
    if args.forces is not None:
        table = read_table(args.forces, required=FORCE_COLUMNS, limit=MAX_INPUT_BYTES)
        forces = ForceHistory(table['t'], np.column_stack([table[n] for n in FORCE_COLUMNS[1:]]))
        sim = simulate(plant, forces=forces, initial=initial, step=args.step)
    else:
        if args.reference is not None:
            table = read_trajectory(args.reference, plant, limit=MAX_INPUT_BYTES)
            cols = [np.column_stack([table[n] for n in TRAJECTORY_COLUMNS[k:k + 3]])
                    for k in (1, 4, 7)]
            reference = Reference.from_samples(table['t'], *cols)
        else:
            reference = Reference.from_motion(MOTIONS[args.motion])
        scene = args.feedforward if args.feedforward is not None else plant.scene
        feedforward = None if scene == 'none' else load_model(args.params, scene,
                                                                   scene_option='--feedforward')
        hz = DEFAULT_BANDWIDTH_HZ if args.bandwidth is None else args.bandwidth
        servo = (Servo(tuple(args.gains[:3]), tuple(args.gains[3:])) if args.gains is not None
                 else servo_for_bandwidth(plant, hz, DEFAULT_DAMPING))
        sim = simulate(plant, reference=reference, feedforward=feedforward,
                       servo=servo, initial=initial, step=args.step)
    columns = [sim.t, sim.q, sim.qd, sim.qdd, sim.length, sim.rate, sim.force]
    names = OUTPUT_COLUMNS
    if sim.pose_error is not None:
        columns += [sim.pose_error, sim.length_error]
        names += ERROR_COLUMNS
    write_csv(args.output, names, np.column_stack(columns),
              text=('status', [str(s) for s in sim.status]))
    summary = (f"simulate: plant scene '{plant.scene}', {len(sim.t)} rows, t = {sim.t[0]:g} to "
               f'{sim.t[-1]:g} s, {sim.outcome}')
    if sim.pose_error is not None:
        e = sim.tracking()
        summary += '; tracking error max (RMS): ' + ', '.join(
            f"{n} {e[n + '_max']:.3g} ({e[n + '_rms']:.3g}) {unit}"
            for n, unit in (('surge', 'm'), ('heave', 'm'), ('roll', 'rad'), ('length', 'm')))
    print(summary, file=sys.stderr if args.output == '-' else sys.stdout)
    report_not_ok('', sim.status, sim.detail, lambda i: f't = {sim.t[i]:.6g} s')
    if sim.outcome != fsd.Status.OK:
        print(f'warning: simulation stopped: {sim.outcome}: {sim.outcome_detail}; '
              f'{len(sim.t)} rows written', file=sys.stderr)
        return 1
    return 0
