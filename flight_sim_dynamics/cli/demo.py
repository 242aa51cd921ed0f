"""End-to-end demo (``flight-sim-dynamics demo``, about 25 s): the node as a
process with the packaged parameters or ``--params`` (any machine; its log
``<output>_node.log``), the demo planner in this process playing the
machine's planner motions, one summary line per second from
``actuator_states`` and ``/diagnostics``, then the forces and powers received
plotted to ``-o``. ``--twin`` adds ``platform_sim`` (the same parameter file:
the node's machine as the plant) on the node's ``actuator_states`` and plots
commanded against simulated motion, every coordinate, to ``<output>_twin.png``.

``--cueing --vehicle LOG.csv`` replaces the planner by the motion-cueing node
(``motion_cueing``, a process on the same parameter file; its log
``<output>_cueing.log``): the vehicle log (columns ``t, f_x, f_y, f_z,
omega_x, omega_y, omega_z``, as ``cue`` reads them) is replayed in real time
as ``sensor_msgs/Imu`` on ``vehicle_imu``, the cueing node's setpoints go to
the node, and the run ends once the platform has washed back to neutral.
"""
from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path
from typing import Any, Sequence

import numpy as np
import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseStamped
from rclpy.node import Node
from rclpy.signals import SignalHandlerOptions
from rclpy.time import Time
from sensor_msgs.msg import Imu, JointState

from ..config.machine_files import example_params_file, load_model_noting
from ..config.files import default_params_path
from ..config.schema import CUEING_TASK
from ..core.machine import Machine
from ..core.motion import PlannerSequence
from ..machines import MACHINES
from ..machines.api import machine_of
from ..ros.dynamics_node import default_qos
from ..ros.node import spin_until
from ..ros.planner import PlannerNode
from ..ros.platform_sim import SIM_TASK
from ..ros.process import (CUEING_MODULE, SIM_MODULE, start_node, stop_node, stop_on_signals,
                           stop_requested)
from ..ros.diagnostics import DIAGNOSTIC_TASK
from ..ros.messages import LEVEL_NAMES, pose_map, quaternion_to_rpy
from ..cueing.vehicles import VEHICLES, vehicle_log
from .csv_io import CsvError
from .cue import VEHICLE_COLUMNS, read_vehicle

#: the built-in vehicle motion --cueing replays without --vehicle
DEFAULT_VEHICLE = 'braking'
#: the rate (Hz) a built-in vehicle motion is sampled at, as a vehicle simulation's IMU
VEHICLE_RATE = 100.0
#: the platform is back at neutral (the cueing run's end) within this (m, rad)
NEUTRAL = 1e-3


class Monitor(Node):
    """Records actuator_states and the node's /diagnostics status."""

    def __init__(self, cueing_task: str | None = None, **kwargs: Any) -> None:
        """``cueing_task``: the motion-cueing node's status task, recorded in
        :attr:`cueing` (None: not recorded).
        """
        super().__init__('demo_monitor', **kwargs)
        self.cueing_task = cueing_task
        self.stamps: list[int] = []
        self.received_at: list[float] = []
        self.position: list[list[float]] = []
        self.velocity: list[list[float]] = []
        self.effort: list[list[float]] = []
        self.status = 'no diagnostics yet'
        self.diagnostics: dict[str, str] = {}
        self.cueing: dict[str, str] = {}        # the motion-cueing node's status values
        self.sub = self.create_subscription(JointState, 'actuator_states', self._on_state,
                                            default_qos())
        self.diag_sub = self.create_subscription(DiagnosticArray, '/diagnostics',
                                                 self._on_diagnostics, 10)

    def _on_state(self, msg: JointState) -> None:
        self.stamps.append(msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec)
        self.received_at.append(self.get_clock().now().nanoseconds)
        self.position.append(list(msg.position))
        self.velocity.append(list(msg.velocity))
        self.effort.append(list(msg.effort))

    def clear(self) -> None:
        """Forget the answers received so far (the diagnostics stay)."""
        for records in (self.stamps, self.received_at, self.position, self.velocity,
                        self.effort):
            records.clear()

    def _on_diagnostics(self, msg: DiagnosticArray) -> None:
        for status in msg.status:
            if self.cueing_task and status.name.endswith(': ' + self.cueing_task):
                self.cueing = {kv.key: kv.value for kv in status.values}
                self.cueing['message'] = status.message
            if status.name.endswith(': ' + DIAGNOSTIC_TASK):
                level = status.level[0] if isinstance(status.level, bytes) else status.level
                self.diagnostics = {kv.key: kv.value for kv in status.values}
                name = LEVEL_NAMES.get(level, str(level))
                self.status = name if status.message in ('', 'OK') else \
                    f'{name} ({status.message})'


def round_trip(executor: Any, planner: PlannerNode, monitor: Monitor,
               timeout: float = 10.0) -> bool:
    """Probe setpoints (at rest, stamped 1 s back, answers not kept) until one is
    answered and the node's diagnostics count a twist and an acceleration: the
    node's own endpoints have matched too (else the stream's first answers can be lost).
    """
    deadline = time.monotonic() + timeout
    answered = False
    while not answered and time.monotonic() < deadline:
        if stop_requested():
            raise KeyboardInterrupt
        stamp = planner.get_clock().now().nanoseconds - 1_000_000_000
        planner.probe(stamp)
        answered = spin_until(executor, lambda: stamp in monitor.stamps[-5:], timeout=0.2)
    if answered:     # the node's diagnostics period (default 1 s) bounds this wait
        spin_until(executor, lambda: all(int(monitor.diagnostics.get(f'received {kind}', 0)) > 0
                                         for kind in ('twist', 'accel')), timeout=3.0)
    monitor.clear()
    return answered


#: Below this real-time factor (mean of the twin's diagnostics periods within
#: the run), or with steps dropped, the demo warns: the twin's poses lag the
#: commands, the tracking figures measure the lag, not the servos.
REAL_TIME_WARNING = 0.9


class TwinMonitor(Node):
    """Records the twin's ``platform_pose`` (or another ``topic`` of poses) as
    (stamp ns, the machine's coordinates) and the twin's /diagnostics as
    (monotonic s received, real-time factor of the period or NaN, steps dropped in all).
    """

    def __init__(self, machine: Machine, topic: str = 'platform_pose',
                 node_name: str = 'demo_twin_monitor', **kwargs: Any) -> None:
        super().__init__(node_name, **kwargs)
        self.poses = pose_map(machine)
        self.rows: list[tuple[float, ...]] = []
        self.speed: list[tuple[float, float, int]] = []
        self.sub = self.create_subscription(PoseStamped, topic, self._on_pose, default_qos())
        self.diag_sub = self.create_subscription(DiagnosticArray, '/diagnostics',
                                                 self._on_diagnostics, 10)

    def _on_diagnostics(self, msg: DiagnosticArray) -> None:
        for status in msg.status:
            if status.name.endswith(': ' + SIM_TASK):
                values = {kv.key: kv.value for kv in status.values}
                try:
                    factor = float(values.get('real-time factor', ''))
                except ValueError:          # 'no samples': the twin not started yet
                    factor = math.nan
                dropped = values.get('steps dropped', '0')
                self.speed.append((time.monotonic(), factor,
                                   int(dropped) if dropped.isdigit() else 0))

    def speed_within(self, start: float, end: float) -> tuple[list[float], int]:
        """The real-time factors of the periods reported within [start, end]
        (monotonic s) and the steps dropped meanwhile.
        """
        before = [d for at, _, d in self.speed if at < start]
        within = [(f, d) for at, f, d in self.speed if start <= at <= end]
        dropped = within[-1][1] - (before[-1] if before else 0) if within else 0
        return [f for f, _ in within if math.isfinite(f)], dropped

    def _on_pose(self, msg: PoseStamped) -> None:
        p, o = msg.pose.position, msg.pose.orientation
        rpy = quaternion_to_rpy(o.x, o.y, o.z, o.w)
        stamp = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec
        self.rows.append((stamp, *self.poses.coordinates((p.x, p.y, p.z, *rpy))))


class ImuReplay(Node):
    """Publishes a vehicle log (times ``t`` s, specific force ``f`` (N, 3),
    angular velocity ``omega`` (N, 3)) as ``sensor_msgs/Imu`` on
    ``vehicle_imu`` in real time from :meth:`start` on, each stamped start +
    its time from the log's first; ``done`` once sent.
    """

    def __init__(self, t: np.ndarray, f: np.ndarray, omega: np.ndarray, **kwargs: Any) -> None:
        super().__init__('demo_vehicle', **kwargs)
        self.t = np.asarray(t, dtype=float) - float(t[0])
        self.f, self.omega = np.asarray(f, dtype=float), np.asarray(omega, dtype=float)
        self.pub = self.create_publisher(Imu, 'vehicle_imu', default_qos(100))
        self._msg = Imu()
        self._msg.header.frame_id = 'vehicle'
        self.sent = 0
        self.done = False
        self.t0_ns = 0
        self._wall0 = 0.0
        self._timer = None

    def subscribers_ready(self) -> bool:
        return self.pub.get_subscription_count() > 0

    def probe(self, stamp_ns: int) -> None:
        """The log's first sample, not counted (the cueing node takes it as its
        rest: the replay then starts from rest).
        """
        self._send(stamp_ns, 0)

    def start(self) -> None:
        self.t0_ns = self.get_clock().now().nanoseconds
        self._wall0 = time.monotonic()
        self._timer = self.create_timer(0.002, self._on_timer)

    def _on_timer(self) -> None:
        elapsed = time.monotonic() - self._wall0
        try:
            while self.sent < len(self.t) and self.t[self.sent] <= elapsed:
                k = self.sent
                self._send(self.t0_ns + round(self.t[k] * 1e9), k)
                self.sent += 1
        except Exception:
            if self.context.ok():
                raise
            self.sent = len(self.t)     # the context was shut down under this callback
        if self.sent >= len(self.t) and not self.done:
            self.done = True
            self._timer.cancel()

    def _send(self, stamp_ns: int, k: int) -> None:
        msg = self._msg
        msg.header.stamp = Time(nanoseconds=stamp_ns).to_msg()
        a, w = msg.linear_acceleration, msg.angular_velocity
        a.x, a.y, a.z = (float(v) for v in self.f[k])
        w.x, w.y, w.z = (float(v) for v in self.omega[k])
        self.pub.publish(msg)


class RecordedMotion:
    """Poses recorded as (stamp ns, q...) rows, read as a planner sequence
    is (:func:`tracking`): ``sample(t)`` the pose interpolated at ``t`` s from
    ``t0_ns``; no segments.
    """

    segments: tuple = ()

    def __init__(self, rows: Sequence[Sequence[float]], t0_ns: int) -> None:
        data = np.array(rows, dtype=float).reshape(len(rows), -1)
        self.t = (data[:, 0] - t0_ns) * 1e-9
        self.q = data[:, 1:]

    def sample(self, t: float) -> tuple[np.ndarray, None, None, str]:
        return (np.array([np.interp(t, self.t, column) for column in self.q.T]), None, None,
                '')


def read_vehicle_log(source: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(t (N,), f (N, 3), omega (N, 3)) of a built-in vehicle motion
    (:data:`..cueing.vehicles.VEHICLES`, at :data:`VEHICLE_RATE`) or of a
    vehicle log as ``cue`` reads it; CsvError naming the line of a time going
    backwards (a repeated time is sent: the cueing node drops and counts it).
    """
    if source in VEHICLES:
        log = vehicle_log(source, VEHICLE_RATE)
        return log.t, log.f, log.omega
    path = source
    table = read_vehicle(path)
    if len(table) < 2:
        raise CsvError('a vehicle log needs two samples at least', path=str(path))
    t = table['t']
    back = np.flatnonzero(np.diff(t) < 0)
    if back.size:
        raise CsvError(f't = {t[back[0] + 1]!r} goes backwards (the line before: '
                       f'{t[back[0]]!r})', path=str(path), line=int(table.lines[back[0] + 1]))
    columns = [table[name] for name in VEHICLE_COLUMNS[1:]]
    return t, np.stack(columns[:3], axis=1), np.stack(columns[3:], axis=1)


class LiveSummary:
    """The demo's one line per second: receive rate since the previous line,
    last forces of the legs ``labels`` (e.g. A/B/C), node status.
    """

    def __init__(self, now: float, labels: Sequence[str] = ('A', 'B', 'C')) -> None:
        self.labels = tuple(labels)
        self.start = self.last_time = now
        self.last_count = 0
        self.printed = 0

    def line(self, now: float, count: int, forces: Sequence[float] | None, status: str,
             final: bool = False) -> str | None:
        """The next line; None for a ``final`` one when nothing arrived since the
        previous line (it would repeat that line at a rate of 0 Hz).
        """
        if final and self.printed and count == self.last_count:
            return None
        self.printed += 1
        rate = (count - self.last_count) / (now - self.last_time) if now > self.last_time else 0.0
        self.last_time, self.last_count = now, count
        text = '  '.join(f'{f:7.2f}' for f in forces) if forces else \
            '  '.join(f'{"-":>4}   ' for _ in self.labels)
        return (f'[demo] t={now - self.start:5.1f} s  rate {rate:6.1f} Hz  '
                f'forces {"/".join(self.labels)} {text} N  status {status}')


SEGMENT_FONT_SIZE = 8      # pt, the motions' names above a figure's first axes


def _shade_segments(axes, sequence: PlannerSequence) -> None:
    """The motions of the sequence as grey bands, named on a top axis of the
    first axes (its title moved above them).
    """
    from matplotlib import rcParams

    centres, names = [], []
    for label, start, end in sequence.segments:
        if label == 'return':
            continue
        for ax in axes:
            ax.axvspan(start, end, color='0.93', zorder=0)
            ax.axvline(start, color='0.6', lw=0.6, zorder=0)
        centres.append(0.5 * (start + end))
        names.append(label)
    top = axes[0].secondary_xaxis('top')
    top.set_xticks(centres, names, fontsize=SEGMENT_FONT_SIZE)
    top.tick_params(length=0, pad=2)
    if axes[0].get_title():     # above the names (matplotlib places it at the axes' top)
        axes[0].set_title(axes[0].get_title(), fontsize='medium',
                          pad=rcParams['axes.titlepad'] + SEGMENT_FONT_SIZE + 4)


def plot(monitor: Monitor, sequence: PlannerSequence | RecordedMotion, t0_ns: int, path: Path,
         labels: Sequence[str] = ('A', 'B', 'C')) -> None:
    """Forces and powers (effort x velocity) of the received messages vs time,
    one curve per leg (``labels``).
    """
    from .plotting import force_power_figure

    t = (np.array(monitor.stamps, dtype=np.int64) - t0_ns) * 1e-9
    force = np.array(monitor.effort)
    fig = force_power_figure(t, force, force * np.array(monitor.velocity),
                             title=f'actuator_states received from the node: {len(t)} messages',
                             actuators=tuple(labels))
    _shade_segments(fig.axes[:2], sequence)
    fig.axes[1].set_xlabel('setpoint stamp (s from start)')
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)


def tracking(monitor: TwinMonitor, sequence: PlannerSequence, t0_ns: int, end_ns: int
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(t s from the start, simulated q (N, dof), commanded q (N, dof)) of the
    poses stamped within the planner's run.
    """
    rows = np.array([r for r in monitor.rows if t0_ns <= r[0] <= end_ns], dtype=float)
    if rows.size == 0:
        dof = len(monitor.poses.names)
        return np.zeros(0), np.zeros((0, dof)), np.zeros((0, dof))
    t = (rows[:, 0] - t0_ns) * 1e-9
    commanded = np.array([sequence.sample(ti)[0] for ti in t])
    return t, rows[:, 1:], commanded


def plot_tracking(t: np.ndarray, simulated: np.ndarray, commanded: np.ndarray,
                  sequence: PlannerSequence, path: Path, machine: Machine = MACHINES[0]) -> None:
    """Commanded against simulated motion, each coordinate of ``machine``, and
    the tracking errors, against time.
    """
    from matplotlib.figure import Figure

    error = simulated - commanded
    dof = machine.dof
    fig = Figure(figsize=(10, 2.25 * (dof + 1)), layout='constrained')
    axes = fig.subplots(dof + 1, 1, sharex=True)
    for i, (name, unit) in enumerate(zip(machine.coordinates, machine.units)):
        axes[i].plot(t, commanded[:, i], color='0.3', lw=2.5, alpha=0.5, label='commanded')
        axes[i].plot(t, simulated[:, i], color='tab:blue', lw=1.0, label='simulated (twin)')
        axes[i].set_ylabel(f'{name} ({unit})')
        axes[dof].plot(t, 1e3 * error[:, i], label=f'{name} (m{unit})')
    axes[dof].set_ylabel('simulated - commanded')
    axes[dof].set_xlabel('stamp (s from start)')
    _shade_segments(axes, sequence)
    for ax in axes:
        ax.grid(True, alpha=0.3)
        ax.legend(loc='upper right', fontsize=8, ncol=1 if dof <= 3 else 2)
    peak = np.abs(error).max(axis=0) if len(t) else np.full(dof, np.nan)
    fig.suptitle(f'digital twin (platform_sim) driven by dynamics_node: {len(t)} poses\nmax error '
                 + ', '.join(f'{name} {1e3 * p:.2f} m{unit}'
                             for name, p, unit in zip(machine.coordinates, peak, machine.units)))
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)


def twin_speed(factors: Sequence[float], dropped: int = 0,
               threshold: float = REAL_TIME_WARNING) -> str:
    """The twin's speed over the run: ``factors`` are the real-time factors of
    its diagnostics periods within the run, ``dropped`` the steps it dropped
    (the plant held still); a line starting ``warning:`` when it did not keep
    real time (the mean below ``threshold``, or steps dropped) or no factor came.
    """
    if not len(factors):
        return ('warning: no real-time factor in the twin\'s diagnostics during the run: '
                'whether it kept real time is unknown')
    mean = float(np.mean(factors))
    figures = (f'{mean:.2f}x real time (mean of {len(factors)} diagnostics periods, '
               f'min {min(factors):.2f}x), {dropped} steps dropped')
    if mean >= threshold and not dropped:
        return f'twin speed {figures}'
    return (f'warning: the twin did not keep real time: {figures}; its poses lag the '
            'commands and the tracking error above measures that lag, not the servos '
            '(the Python loop instead of the compiled kernel, docs/kernel.md, or a loaded '
            'host)')


def twin_summary(t: np.ndarray, simulated: np.ndarray, commanded: np.ndarray,
                 machine: Machine = MACHINES[0]) -> str:
    """One line: poses and max / RMS tracking error per coordinate."""
    if not len(t):
        return 'no twin pose received within the run'
    e = simulated - commanded
    peak, rms = np.abs(e).max(axis=0), np.sqrt((e * e).mean(axis=0))
    return (f'{len(t)} twin poses; tracking error max / RMS: ' + ', '.join(
        f'{name} {1e3 * p:.2f} / {1e3 * r:.2f} m{unit}'
        for name, unit, p, r in zip(machine.coordinates, machine.units, peak, rms)))


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog='flight-sim-dynamics demo',
        description='Start the dynamics node with the packaged parameters (or --params: '
                    'any machine), drive it with the demo planner (the machine\'s planner '
                    'motions), print a live summary and plot the forces and powers received '
                    'on actuator_states.')
    parser.add_argument('-o', '--output', default='out/demo.png', type=Path,
                        help='PNG to write (default: out/demo.png)')
    parser.add_argument('--rate', type=float, default=None, metavar='HZ',
                        help='planner rate (default: 100 Hz); with --cueing: the cueing '
                             "node's output rate, cueing.rate (default: the parameter file's)")
    parser.add_argument('--motions', nargs='+', default=None, metavar='NAME',
                        help="motions to play, of the machine's planner motions ("
                             + '; '.join(f"{m.title}: {', '.join(m.planner_motions)}"
                                         for m in MACHINES) + '; default: all of them)')
    parser.add_argument('--params', '--params-file', type=Path, default=None, metavar='FILE',
                        help='node parameter file, naming the machine (e.g. '
                             f"{example_params_file()}; default: the {MACHINES[0].title}'s "
                             'packaged file)')
    parser.add_argument('--twin', action='store_true',
                        help='also run the twin node platform_sim on the node\'s actuator_states '
                             'and plot commanded against simulated motion to <output>_twin.png')
    parser.add_argument('--cueing', action='store_true',
                        help='drive the node through the motion-cueing node (motion_cueing, on '
                             'the same parameter file) with the vehicle motion of --vehicle '
                             'instead of the demo planner')
    parser.add_argument('--vehicle', default=None, metavar='LOG.csv|NAME',
                        help='with --cueing: the vehicle motion replayed as sensor_msgs/Imu on '
                             'vehicle_imu: a vehicle log as cue reads it (columns '
                             + ', '.join(VEHICLE_COLUMNS) + '; SI, vehicle body axes, REP-103; '
                             'extra columns ignored) or a built-in motion, at '
                             f'{VEHICLE_RATE:g} Hz (' + ', '.join(VEHICLES) + '; default: '
                             f'{DEFAULT_VEHICLE})')
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the demo; 0 when every setpoint was answered."""
    argv = list(sys.argv[1:] if argv is None else argv)
    args = build_parser().parse_args(rclpy.utilities.remove_ros_args(['demo', *argv])[1:])
    # Ctrl-C requests a stop, seen between callbacks (as in the node executables):
    # no KeyboardInterrupt raised inside a timer callback
    stop_on_signals()
    params_file = args.params or default_params_path()
    parser = build_parser()
    try:
        model, notes = load_model_noting(params_file)
    except (OSError, ValueError) as exc:
        parser.error(f'--params: {exc}')
    machine = machine_of(model)
    for note in notes:          # the node logs them too, in its log file
        print(f'[demo] note: --params {note}')
    if args.vehicle is not None and not args.cueing:
        parser.error('--vehicle: the vehicle motion drives the cueing node: add --cueing')
    if args.cueing and args.vehicle is None:
        args.vehicle = DEFAULT_VEHICLE
    if args.cueing and args.motions:
        parser.error('--motions: the demo planner\'s; --cueing replays --vehicle instead')
    if args.rate is not None and not 0 < args.rate <= 10000:
        parser.error('--rate must be in (0, 10000] Hz')
    vehicle = None
    if args.vehicle is not None:
        try:
            vehicle = read_vehicle_log(args.vehicle)
        except (OSError, CsvError) as exc:
            parser.error(f'--vehicle: {exc}')
    names = args.motions or list(machine.planner_motions)
    unknown = [name for name in names if name not in machine.planner_motions]
    if unknown:
        parser.error(f'--motions: {unknown[0]!r} is not a motion of the {machine.title}; '
                     f"choose from {', '.join(machine.planner_motions)}")
    args.output.parent.mkdir(parents=True, exist_ok=True)
    log_path = args.output.with_name(args.output.stem + '_node.log')   # next to the PNG
    sequence: PlannerSequence | RecordedMotion = PlannerSequence(machine.motions, names)
    print(f'[demo] {machine.title}; starting the node: dynamics_node --ros-args '
          f'--params-file {params_file}')
    print(f'[demo] node log: {log_path}')
    node_proc = start_node(params_file, log=log_path)
    twin_log = args.output.with_name(args.output.stem + '_twin.log')
    # the twin reads the node's answers (one remap); the node's file: its model is the plant
    twin_args = ('-r', 'actuator_commands:=actuator_states')
    twin_proc = start_node(params_file, twin_args, log=twin_log,
                           module=SIM_MODULE) if args.twin else None
    if twin_proc is not None:
        print(f'[demo] starting the twin: platform_sim --ros-args --params-file {params_file} '
              f'-r actuator_commands:=actuator_states (log: {twin_log})')
    cue_log = args.output.with_name(args.output.stem + '_cueing.log')
    cue_args = ('-p', f'cueing.rate:={args.rate!r}') if args.rate is not None else ()
    cue_proc = start_node(params_file, cue_args, log=cue_log, module=CUEING_MODULE) \
        if args.cueing else None
    if cue_proc is not None:
        print(f'[demo] starting the cueing node: motion_cueing --ros-args --params-file '
              f"{params_file} {' '.join(cue_args)}".rstrip() + f' (log: {cue_log})')
    if args.rate is None:
        args.rate = 100.0           # the planner's
    context = rclpy.Context()
    rclpy.init(args=['demo', *argv], context=context,
               signal_handler_options=SignalHandlerOptions.NO)
    from rclpy.experimental import EventsExecutor
    executor = EventsExecutor(context=context)
    if vehicle is None:
        source: Any = PlannerNode(sequence, args.rate, machine=machine, context=context)
        monitor = Monitor(context=context)
        setpoints = None
    else:
        source = ImuReplay(*vehicle, context=context)
        monitor = Monitor(CUEING_TASK, context=context)
        setpoints = TwinMonitor(machine, 'pose_setpoint', 'demo_setpoints', context=context)
    twin = TwinMonitor(machine, context=context) if twin_proc is not None else None
    side = [n for n in (source, monitor, setpoints, twin) if n is not None]
    for n in side:
        executor.add_node(n)
    processes = [(node_proc, 'node', log_path), (twin_proc, 'twin', twin_log),
                 (cue_proc, 'cueing node', cue_log)]

    def down() -> str | None:
        """The first process that ended, with the end of its log."""
        for proc, what, log in processes:
            if proc is not None and proc.poll() is not None:
                return f'[demo] the {what} exited; its log:\n' + log.read_text()[-2000:]
        return None

    def spin(predicate: Any, timeout: float | None = None) -> bool:
        done = spin_until(executor, predicate, timeout)
        if stop_requested():
            raise KeyboardInterrupt
        return done

    try:
        ready = spin(lambda: (
            source.subscribers_ready() and monitor.sub.get_publisher_count() > 0
            and (twin is None or twin.sub.get_publisher_count() > 0)
            and (setpoints is None or setpoints.sub.get_publisher_count() > 0)
            or down() is not None), timeout=20.0)
        if not ready or down() is not None:
            print(down() or '[demo] the nodes did not come up in 20 s; the node log:\n'
                  + log_path.read_text()[-2000:])
            return 1
        if vehicle is None:
            if not round_trip(executor, source, monitor):
                print('[demo] no probe setpoint answered in 10 s; the node log:\n'
                      + log_path.read_text()[-2000:])
                return 1
            print(f'[demo] node up; planner: {", ".join(sequence.names)} at {args.rate:g} Hz, '
                  f'{sequence.period:.1f} s')
        else:
            if not cueing_round_trip(executor, source, monitor):
                print('[demo] the cueing node\'s setpoints not answered, or its vehicle_imu '
                      'not matched, in 20 s; its log:\n' + cue_log.read_text()[-2000:])
                return 1
            print(f'[demo] nodes up; replaying {args.vehicle} ({len(source.t)} samples, '
                  f'{source.t[-1]:.1f} s) as vehicle_imu')
        source.start()
        run_start = time.monotonic()
        t0_ns = source.t0_ns if vehicle is not None else source._t0_ns
        labels = tuple(label.upper() for label in machine.leg_labels)
        live = LiveSummary(time.monotonic(), labels)

        def summary(final: bool = False) -> None:
            text = live.line(time.monotonic(), len(monitor.stamps),
                             monitor.effort[-1] if monitor.effort else None, monitor.status,
                             final)
            if text is not None:
                print(text, flush=True)

        while not source.done:
            spin(lambda: source.done or time.monotonic() - live.last_time >= 1.0)
            if down() is not None:
                print(down())
                return 1
            if time.monotonic() - live.last_time >= 1.0:
                summary()
        if setpoints is not None:
            print('[demo] vehicle log sent; the platform washes back to neutral')
            back = spin(lambda: monitor.cueing.get('input') == 'stale' and at_neutral(
                setpoints.rows, t0_ns) or down() is not None, timeout=60.0)
            if down() is not None:
                print(down())
                return 1
            if not back:
                print('[demo] the platform was not back at neutral within 60 s')
            stamps = [int(r[0]) for r in setpoints.rows if r[0] >= t0_ns]
            sequence = RecordedMotion([r for r in setpoints.rows if r[0] >= t0_ns], t0_ns)
        else:
            stamps = []
        sent = len(stamps) if setpoints is not None else source.sent
        answered = set(monitor.stamps)
        spin(lambda: (all(s in answered for s in stamps[-5:]) if setpoints is not None
                      else len(monitor.stamps) >= source.sent), timeout=5.0)
        answered = set(monitor.stamps)
        run_end = time.monotonic()
        summary(final=True)
        received = sum(s in answered for s in stamps) if setpoints is not None \
            else len(monitor.stamps)
        latency = sorted((r - s) * 1e-6 for r, s in zip(monitor.received_at, monitor.stamps))
        lat = (f'latency stamp->received median {latency[len(latency) // 2]:.1f} ms, '
               f'max {latency[-1]:.1f} ms' if latency else '')
        print(f'[demo] sent {sent} setpoints, received {received} actuator_states '
              f'({sent - received} missing); {lat}')
        d = monitor.diagnostics
        if d:
            fields = (('solve time mean', 'solve time mean (us)', ' us'),
                      ('rejected', 'rejected total', ''), ('cond(Q)', 'cond(Q) last', ''),
                      ('limit exceeded', 'limit exceeded', ''))
            # the reasons of the rejected messages, when any (diagnostics keys 'rejected <reason>')
            reasons = ', '.join(f'{k[9:]} {v}' for k, v in d.items()
                                if k.startswith('rejected ') and k != 'rejected total'
                                and v not in ('0', 0))
            print('[demo] node diagnostics: ' + ', '.join(
                f'{label} {d[key]}{unit}' + (f' ({reasons})' if key == 'rejected total'
                                             and reasons else '')
                for label, key, unit in fields if key in d))
        c = monitor.cueing
        if c:
            limits = ', '.join(f'{k[6:]} {v}' for k, v in c.items()
                               if k.startswith('limit ') and k != 'limit last') or 'none'
            print(f"[demo] cueing diagnostics: vehicle_imu accepted {c.get('imu accepted')}, "
                  f"rejected {c.get('rejected total')}; samples limited "
                  f"{c.get('samples limited total')} (limits: {limits}); step time mean "
                  f"{c.get('step time mean (us)')} us")
        if received:
            plot(monitor, sequence, t0_ns, args.output, labels)
            print(f'[demo] forces and powers plotted to {args.output}')
        twin_ok = True
        if twin is not None:
            end_ns = stamps[-1] if setpoints is not None else \
                t0_ns + round((source.sent - 1) * 1e9 / args.rate)
            spin(lambda: bool(twin.rows) and twin.rows[-1][0] >= end_ns,
                 timeout=3.0)
            t, simulated, commanded = tracking(twin, sequence, t0_ns, end_ns)
            print(f'[demo] twin: {twin_summary(t, simulated, commanded, machine)}')
            print('[demo] ' + twin_speed(*twin.speed_within(run_start, run_end)))
            twin_ok = len(t) > 0 and twin_proc.poll() is None
            if len(t):
                twin_png = args.output.with_name(args.output.stem + '_twin.png')
                plot_tracking(t, simulated, commanded, sequence, twin_png, machine)
                print(f'[demo] commanded against simulated motion plotted to {twin_png}')
        return 0 if received == sent and received > 0 and twin_ok else 1
    except KeyboardInterrupt:
        return 130
    finally:
        for proc, _, _ in processes:
            if proc is not None:
                stop_node(proc)
        for n in side:
            n.destroy_node()
        rclpy.try_shutdown(context=context)


def at_neutral(rows: Sequence[Sequence[float]], t0_ns: int) -> bool:
    """The last recorded pose, stamped after ``t0_ns``, within :data:`NEUTRAL` of home."""
    return bool(rows) and rows[-1][0] > t0_ns and max(map(abs, rows[-1][1:])) < NEUTRAL


def cueing_round_trip(executor: Any, replay: ImuReplay, monitor: Monitor,
                      timeout: float = 20.0) -> bool:
    """The cueing node's setpoints (at neutral from its activation on) answered
    by the node, then the log's first sample sent (stamped 1 s back) until the
    cueing node's diagnostics count it: every link has matched. The answers so
    far are forgotten.
    """
    deadline = time.monotonic() + timeout
    if not spin_until(executor, lambda: bool(monitor.stamps), timeout):
        return False
    while time.monotonic() < deadline:
        if stop_requested():
            raise KeyboardInterrupt
        replay.probe(replay.get_clock().now().nanoseconds - 1_000_000_000)
        if spin_until(executor, lambda: monitor.cueing.get('imu accepted', '0') != '0', 1.0):
            monitor.clear()
            return True
    return False


if __name__ == '__main__':
    sys.exit(main())
