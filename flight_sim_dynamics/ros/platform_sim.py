"""The twin node ``platform_sim``: the machine without the machine (docs/twin.md).

A command is checked as it arrives and kept; the tick (``tick_rate``) holds
the newest one from its arrival on, makes the RK4 steps due at ``rate``
(:class:`..core.twin.TwinStepper`) and publishes the state. So a burst of
commands costs a decode and a check each, never the loop its rate: commands
a newer one replaced before a tick are counted, not simulated. The plant is
a model of any machine (its parameter file names it): its legs are the
commands' names, its pose goes out as the setpoints carry a pose
(:class:`.messages.PoseMap`: position surge, sway, heave; ZYX roll, pitch,
yaw; the twist's angular part the base-frame angular velocity, (S2)).
"""
from __future__ import annotations

import contextlib
import math
import time
from dataclasses import dataclass
from typing import Any, Mapping, Sequence

import numpy as np

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import Point, Pose, PoseStamped, Quaternion, Twist, TwistStamped, Vector3
from rclpy.clock import Clock, ClockType
from rclpy.exceptions import ParameterUninitializedException
from rclpy.node import Node
from rclpy.serialization import deserialize_message
from rclpy.time import Time
from sensor_msgs.msg import JointState
from std_msgs.msg import Header
from std_srvs.srv import Trigger

from ..config import parameters as prm
from ..config.files import NODE_NAME, ROS_PARAMETERS, section_applies
from ..config.machine_files import load_model
from ..config.schema import SIM_NODE_NAME, SIM_PARAMETERS
from ..config.yaml_io import read_yaml
from ..core.machine import ActuatorLimits, Machine
from ..core.servo import Servo
from ..core.twin import TwinStepper
from ..machines.api import machine_of
from .dynamics_node import default_qos
from .parameter_guard import _declared, descriptor_for, plain
from .process import end_spins, stop_requested
from .diagnostics import LogThrottle, diagnostic_name, log_at, number
from .join import RestartRule
from .messages import (ERROR, LEVEL_NAMES, NON_FINITE, OK, STAMP_BACKWARDS, STAMP_REPEATED, WARN,
                       SetpointError, pose_map, rpy_to_quaternion)

#: Seconds between two log lines of one rejection reason.
LOG_THROTTLE = 2.0
UNDECODABLE = 'undecodable'      # bytes that are no JointState
BAD_NAMES = 'bad_names'          # names that are not the machine's legs, once each
BAD_SIZE = 'bad_size'            # an array of another size than the legs (or 0: velocity, effort)
BEYOND_LIMITS = 'beyond_limits'  # no command the machine could be sent (LIMIT_MARGIN)
#: Why a command is rejected, in the order /diagnostics lists them.
COMMAND_REASONS = (UNDECODABLE, BAD_NAMES, BAD_SIZE, NON_FINITE, BEYOND_LIMITS,
                   STAMP_REPEATED, STAMP_BACKWARDS)
#: A command beyond this many times the force or speed limit, or a stroke
#: beyond the stroke range by more than the range itself, is a fault upstream:
#: held, the servos would drive the plant out of its workspace at full force.
LIMIT_MARGIN = 10.0
#: The status name of the twin in /diagnostics (``<node>: <task>``).
SIM_TASK = 'platform simulation'


@dataclass(frozen=True)
class SimConfig:
    """The twin's validated parameters, the plant (a model of ``machine``), its
    servos, its limits and the length each leg's stroke is measured from.
    """

    values: Mapping[str, Any]
    machine: Machine
    plant: Any
    servo: Servo
    limits: ActuatorLimits
    stroke_origin: np.ndarray

    def stepper(self) -> TwinStepper:
        return TwinStepper(self.machine, self.plant, self.servo, 1.0 / self.values['rate'],
                           self.values['initial'] or None)


def plant_file(given: str, params_files: Sequence[str],
               node: str = '/' + NODE_NAME, key: str = 'plant.params_file') -> str | None:
    """The plant's parameter file: ``given`` (the parameter ``key``), else the one
    ``--params-file`` of the command line with a section for the dynamics node
    ``node`` (fully qualified: the twin's namespace; the node's file serves the
    twin, and the motion-cueing node, too), else None (the packaged parameters).
    """
    if given:
        return given
    found = []
    for path in params_files:
        try:
            doc = read_yaml(path, 'params_file')
        except (OSError, ValueError):
            continue                     # rcl reads it as the twin's own: its error first
        if isinstance(doc, Mapping) and any(section_applies(str(section), node)
                                            for section in doc):
            found.append(path)
    if len(found) > 1:
        raise prm.ParameterError(key, '', f'{len(found)} --params-file files '
                                 f"have a section for {NODE_NAME} ({', '.join(found)}): "
                                 f"name the machine's with {key}")
    return found[0] if found else None


def sim_config(values: Mapping[str, Any], params_files: Sequence[str] = (),
               node: str = '/' + NODE_NAME) -> SimConfig:
    """The checked parameters (defaults for the absent ones), plant and servos;
    ``params_files``: the ``--params-file`` files of the command line, ``node``
    the dynamics node whose section names the plant (:func:`plant_file`).
    ParameterError also for a scene without inertia, a pose of another size
    than the machine's or one the plant cannot take.
    """
    checked = {spec.name: prm.check_value(spec, values.get(spec.name, spec.default))
               for spec in SIM_PARAMETERS}
    path = plant_file(checked['plant.params_file'], params_files, node)
    try:
        plant = load_model(path, checked['plant.scene'] or None)
    except prm.SceneError as exc:
        raise prm.ParameterError('plant.scene', checked['plant.scene'], str(exc)) from None
    except (OSError, ValueError) as exc:
        raise prm.ParameterError('plant.params_file', path or '', str(exc)) from None
    machine = machine_of(plant)
    if checked['initial'] and len(checked['initial']) != machine.dof:
        raise prm.ParameterError('initial', checked['initial'], f'expected {machine.dof} '
                                 f"numbers ({', '.join(machine.coordinates)}) or none (home)")
    if checked['tick_rate'] > checked['rate']:
        raise prm.ParameterError('tick_rate', checked['tick_rate'],
                                 f"must not exceed rate ({checked['rate']:g} Hz): a tick "
                                 'makes whole steps')
    home = machine.solve(plant, *(np.zeros(machine.dof),) * 3)
    try:
        servo = Servo.for_bandwidth(machine, plant, checked['servo.bandwidth'],
                                    checked['servo.damping'])
        config = SimConfig(checked, machine, plant, servo, machine.actuator_limits(plant),
                           np.asarray(home.length) - np.asarray(home.stroke))
        twin = config.stepper()
    except ValueError as exc:           # a scene without inertia
        raise prm.ParameterError('plant.scene', checked['plant.scene'], str(exc)) from None
    if not twin.running:
        raise prm.ParameterError('initial', checked['initial'],
                                 f'the plant cannot start there: {twin.outcome}: {twin.detail}')
    return config


Command = tuple[tuple[float, ...], tuple[float, ...], tuple[float, ...]]


def check_command(names: Sequence[str], position: Sequence[float],
                  velocity: Sequence[float], effort: Sequence[float], config: SimConfig
                  ) -> Command:
    """(length, rate, force) of a command, one number per leg of the plant's
    machine in its order; raises :class:`SetpointError` with the reason
    (:data:`COMMAND_REASONS`; the stamp is checked by :meth:`CommandStats.stamp`).
    """
    legs = config.machine.legs
    n = len(legs)
    if len(names) != n or sorted(names) != sorted(legs):
        raise SetpointError(BAD_NAMES, f'names must be {", ".join(legs)} once each, '
                                       f'got {list(names)!r:.200}')
    order = [names.index(leg) for leg in legs]
    out = []
    for what, values in (('position', position), ('velocity', velocity), ('effort', effort)):
        if len(values) != n and (what == 'position' or len(values)):
            raise SetpointError(BAD_SIZE, f'{what} must have {n} values'
                                + ('' if what == 'position' else ' or none')
                                + f', got {len(values)}')
        picked = tuple(float(values[i]) for i in order) if len(values) else (0.0,) * n
        if not all(math.isfinite(v) for v in picked):
            raise SetpointError(NON_FINITE, f'{what} has a non-finite value {picked!r}')
        out.append(picked)
    lim = config.limits
    span = lim.stroke_max - lim.stroke_min
    for what, values, low, high in (
            ('stroke (m)', [v - v0 for v, v0 in zip(out[0], config.stroke_origin)],
             lim.stroke_min - span, lim.stroke_max + span),
            ('rate (m/s)', out[1], [-LIMIT_MARGIN * lim.max_speed] * n,
             [LIMIT_MARGIN * lim.max_speed] * n),
            ('force (N)', out[2], [-LIMIT_MARGIN * lim.max_force] * n,
             [LIMIT_MARGIN * lim.max_force] * n)):
        if not all(lo <= v <= hi for v, lo, hi in zip(values, low, high)):
            raise SetpointError(BEYOND_LIMITS, f'{what} {[f"{v:.4g}" for v in values]} beyond '
                                               f'[{min(low):.4g}, {max(high):.4g}]')
    return out[0], out[1], out[2]


class CommandStats:
    """Counters of the commands, stamp order, and the real-time figures of
    the loop (per diagnostics period: ticks, their work time, simulated time).
    """

    def __init__(self) -> None:
        self.received = 0
        self.accepted = 0
        self.superseded = 0                  # accepted, replaced by a newer one before a tick
        self.rejected = {reason: 0 for reason in COMMAND_REASONS}
        self.restarts = 0
        self.last_rejection = ''
        self.last_stamp: int | None = None
        self._restart = RestartRule()      # any stamps before the last: a planner restarted
        self.overruns = 0                    # ticks late or with dropped steps, total
        self.dropped_steps = 0
        self.new_period(None, 0.0)

    def new_period(self, now: float | None, sim_time: float) -> None:
        self._start, self._sim_start = now, sim_time
        self._work: list[float] = []
        self._rejected_at_start = sum(self.rejected.values())
        self._overruns_at_start = self.overruns

    def stamp(self, stamp_ns: int) -> None:
        """Accept a command's stamp or raise SetpointError; stamps before the
        last accepted one that confirm a restart (:class:`.join.RestartRule`)
        are accepted.
        """
        last = self.last_stamp
        if last is not None and stamp_ns <= last:
            if not self._restart.confirms(stamp_ns, last):
                if stamp_ns == last:
                    raise SetpointError(STAMP_REPEATED, f'stamp {stamp_ns} ns repeated')
                raise SetpointError(STAMP_BACKWARDS, f'stamp {stamp_ns} ns before the last '
                                                     f'accepted one ({last} ns)')
            self.restarts += 1
        self._restart.clear()
        self.last_stamp = stamp_ns

    def reject(self, reason: str, message: str) -> None:
        self.rejected[reason] += 1
        self.last_rejection = f'{reason}: {message}'

    def tick(self, work: float, period: float, dropped: int) -> None:
        """One tick: its work time (s) against its period, steps it dropped."""
        self._work.append(work)
        if dropped or work > period:
            self.overruns += 1
            self.dropped_steps += dropped

    def report(self, now: float, twin: TwinStepper, started: bool, rate: float
               ) -> tuple[int, str, list[tuple[str, str]]]:
        """(level, message, [(key, value), ...]) of this period, and a new one:
        ERROR stopped; WARN rejections, overruns or the plant beyond a limit.
        """
        wall = now - self._start if self._start is not None else math.nan
        simulated = twin.time - self._sim_start
        factor = simulated / wall if started and wall > 0 else math.nan
        work = sorted(self._work)
        n = len(work)
        rejected = sum(self.rejected.values()) - self._rejected_at_start
        overruns = self.overruns - self._overruns_at_start
        if not twin.running:
            level, problems = ERROR, [f'stopped: {twin.outcome}: {twin.detail}']
        else:
            problems = [text for show, text in (
                (rejected, f'{rejected} commands rejected'), (overruns, f'{overruns} overruns'),
                (str(twin.status) != 'ok', f'plant {twin.status}: {twin.status_detail}')) if show]
            level = WARN if problems else OK
        message = ('; '.join(problems) if problems
                   else 'waiting for commands' if not started else 'OK')
        values = [
            ('status', LEVEL_NAMES[level]),
            ('plant', twin.plant.scene),
            ('outcome', str(twin.outcome) if twin.running else f'{twin.outcome}: {twin.detail}'),
            ('plant status', str(twin.status)),
            ('rate (Hz)', f'{rate:g}'),
            ('real-time factor', number(factor, '.4f')),
            ('simulated time (s)', f'{twin.time:.3f}'),
            ('steps', str(twin.steps)),
            ('tick work mean (us)', number(1e6 * sum(work) / n if n else math.nan, '.1f')),
            ('tick work max (us)', number(1e6 * work[-1] if n else math.nan, '.1f')),
            ('ticks this period', str(n)),
            ('overruns', str(self.overruns)),
            ('overruns this period', str(overruns)),
            ('steps dropped', str(self.dropped_steps)),
            ('commands received', str(self.received)),
            ('commands accepted', str(self.accepted)),
            ('commands superseded', str(self.superseded)),
            ('rejected total', str(sum(self.rejected.values()))),
        ]
        values += [(f'rejected {reason}', str(count)) for reason, count in self.rejected.items()]
        values += [('stream restarts', str(self.restarts)),
                   ('last rejection', self.last_rejection)]
        self.new_period(now, twin.time)
        return level, message, values


class PlatformSim(Node):
    """The twin node; ``params_files``: the ``--params-file`` files of its
    command line (:func:`plant_file`); ``kwargs`` go to rclpy's Node; bad
    parameters raise ParameterError.
    """

    def __init__(self, params_files: Sequence[str] = (), **kwargs: Any) -> None:
        super().__init__(SIM_NODE_NAME, automatically_declare_parameters_from_overrides=True,
                         **kwargs)
        given = set(self.list_parameters([], 0).names) - ROS_PARAMETERS
        for name in given:
            self.undeclare_parameter(name)      # re-declared below with our descriptors
        # an empty default (initial: home) declares the type alone: rclpy would take
        # an empty list for a byte array
        declared = [_declared(spec, spec.default) for spec in SIM_PARAMETERS]
        self.declare_parameters('', [(p.name, p.value if p.value != [] else p.type_,
                                      descriptor_for(spec, read_only=True))
                                     for p, spec in zip(declared, SIM_PARAMETERS)])
        unknown = sorted(name for name in given if not self.has_parameter(name))
        if unknown:
            self.get_logger().warn('ignoring unknown parameters (typo?): ' + ', '.join(unknown))
        values = {}
        for spec in SIM_PARAMETERS:
            with contextlib.suppress(ParameterUninitializedException):   # not given
                values[spec.name] = plain(self.get_parameter(spec.name).value)
        # the dynamics node next to it: in its namespace
        node = f"{self.get_namespace().rstrip('/')}/{NODE_NAME}"
        self.config = sim_config(values, params_files, node)
        values = self.config.values
        self.stats = CommandStats()
        self._rate = values['rate']
        self._tick_period = 1.0 / values['tick_rate']
        self._max_steps = max(1, int(values['max_catch_up'] * self._rate))
        self._throttle = LogThrottle(LOG_THROTTLE)
        self._rest()

        self._pose_pub = self.create_publisher(PoseStamped, 'platform_pose', default_qos())
        self._twist_pub = self.create_publisher(TwistStamped, 'platform_twist', default_qos())
        self._measured_pub = self.create_publisher(JointState, 'measured_actuator_states',
                                                   default_qos())
        # raw: a message that does not decode is counted, not lost inside rclpy
        self._command_sub = self.create_subscription(JointState, 'actuator_commands',
                                                     self._on_command, default_qos(), raw=True)
        self._reset_srv = self.create_service(Trigger, '~/reset', self._on_reset)
        self._diag_pub = self.create_publisher(DiagnosticArray, '/diagnostics', 10)
        self._diag_name = diagnostic_name(self.get_fully_qualified_name(), SIM_TASK)
        # Timers on the steady clock: they keep ticking with use_sim_time and no /clock.
        steady = Clock(clock_type=ClockType.STEADY_TIME)
        self._tick_timer = self.create_timer(self._tick_period, self._on_tick, clock=steady)
        self._diag_timer = self.create_timer(values['diagnostics.period'],
                                             self._on_diagnostics, clock=steady)
        self.get_logger().info(
            f"ready: {self.config.machine.title}, plant scene {self.config.plant.scene}, RK4 "
            f"at {self._rate:g} Hz, ticks at {values['tick_rate']:g} Hz, servo "
            f"{values['servo.bandwidth']:g} Hz (kp "
            f"{', '.join(f'{k:.4g}' for k in self.config.servo.kp)} N/m); waiting for commands")

    def _rest(self) -> None:
        """At rest at ``initial``, waiting for a first command (any stamp)."""
        self.twin = self.config.stepper()
        self.stats.last_stamp = None
        self.stats.new_period(time.monotonic(), 0.0)
        self._pending: tuple[float, Command] | None = None  # (arrival, command)
        self._started_at: float | None = None    # monotonic time of the first command
        self._stamp0 = 0                         # ROS time (ns) of simulated time 0
        self._dropped = 0                        # steps dropped after stalls

    def _catch_up(self, now: float) -> int:
        """Make the steps due at ``now``; the steps dropped beyond ``max_catch_up``."""
        if self._started_at is None or not self.twin.running:
            return 0
        due = int((now - self._started_at) * self._rate) - self.twin.steps - self._dropped
        dropped = max(0, due - self._max_steps)
        self._dropped += dropped
        if due - dropped > 0:
            self.twin.advance(due - dropped)
        return dropped

    def _on_tick(self) -> None:
        try:
            start = time.monotonic()
            dropped = 0
            if self._pending is not None:
                arrival, command = self._pending
                self._pending = None
                if self._started_at is None:
                    self._started_at = arrival
                    self._stamp0 = self.get_clock().now().nanoseconds - round(
                        (start - arrival) * 1e9)
                    self.get_logger().info('first command: the simulation runs')
                dropped = self._catch_up(arrival)      # the held command up to its arrival
                self.twin.command(*command)
            dropped += self._catch_up(start)
            self._publish()
            if self._started_at is not None:
                self.stats.tick(time.monotonic() - start, self._tick_period, dropped)
        except Exception as exc:  # noqa: BLE001 - nothing escapes a callback
            self._internal_error(exc)

    def _on_command(self, data: bytes) -> None:
        """Decode and check a command; keep it for the next tick."""
        if stop_requested():        # stopping: the spin returns after this callback
            end_spins()
            return
        stats = self.stats
        try:
            now = time.monotonic()
            stats.received += 1
            try:
                try:
                    msg = deserialize_message(data, JointState)
                except Exception as exc:  # noqa: BLE001 - rclpy's RMWError, a private type
                    raise SetpointError(UNDECODABLE, f'{len(data)} bytes: {exc}') from None
                command = check_command(msg.name, msg.position, msg.velocity, msg.effort,
                                        self.config)
                stats.stamp(msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec)
            except SetpointError as exc:
                stats.reject(exc.reason, str(exc))
                self._log(exc.reason, f'command rejected ({exc.reason}): {exc}')
                return
            stats.superseded += self._pending is not None
            self._pending = (now, command)
            stats.accepted += 1
        except Exception as exc:  # noqa: BLE001
            self._internal_error(exc)

    def _on_reset(self, request: Trigger.Request, response: Trigger.Response
                  ) -> Trigger.Response:
        """Back at rest at ``initial``, the stop and the stamp order cleared."""
        twin = self.twin
        was = 'running' if twin.running else f'stopped: {twin.outcome}: {twin.detail}'
        self._rest()
        response.success = True
        response.message = f"at rest at {list(self.config.values['initial'])} (was {was})"
        self.get_logger().info('reset: ' + response.message)
        return response

    def _log(self, key: str, text: str, error: bool = False) -> None:
        """At most one line per ``key`` per :data:`LOG_THROTTLE` s."""
        skipped = self._throttle(key, time.monotonic())
        if skipped is not None:
            more = f' ({skipped} more since the last line)' if skipped else ''
            log_at(self.get_logger(), ERROR if error else WARN, text + more)

    def _internal_error(self, exc: Exception) -> None:
        self._log('internal', f'internal error (the node carries on): '
                              f'{type(exc).__name__}: {exc}', error=True)

    def _publish(self) -> None:
        """The state at its simulated time (ROS now before it starts, once stopped)."""
        twin = self.twin
        if self._started_at is None or not twin.running:
            stamp_ns = self.get_clock().now().nanoseconds
        else:
            stamp_ns = self._stamp0 + round((twin.steps + self._dropped) * 1e9 / self._rate)
        header = Header(stamp=Time(nanoseconds=stamp_ns).to_msg(),
                        frame_id=self.config.values['frame_id'])
        poses = pose_map(self.config.machine)
        q, qd = twin.q.tolist(), twin.qd.tolist()
        x, y, z, *rpy = poses.message(q)
        xd, yd, zd, wx, wy, wz = poses.twist(q, qd)
        ox, oy, oz, w = rpy_to_quaternion(*rpy)
        self._pose_pub.publish(PoseStamped(header=header, pose=Pose(
            position=Point(x=x, y=y, z=z), orientation=Quaternion(x=ox, y=oy, z=oz, w=w))))
        self._twist_pub.publish(TwistStamped(header=header, twist=Twist(
            linear=Vector3(x=xd, y=yd, z=zd), angular=Vector3(x=wx, y=wy, z=wz))))
        self._measured_pub.publish(JointState(
            header=header, name=self.config.machine.legs, position=twin.length.tolist(),
            velocity=twin.rate.tolist(), effort=twin.force.tolist()))

    def _on_diagnostics(self) -> None:
        try:
            level, message, values = self.stats.report(
                time.monotonic(), self.twin, self._started_at is not None, self._rate)
            if level == ERROR:
                self._log('stopped', message, error=True)
            msg = DiagnosticArray(status=[DiagnosticStatus(
                level=bytes([level]), name=self._diag_name, message=message,
                hardware_id=SIM_NODE_NAME, values=[KeyValue(key=k, value=v) for k, v in values])])
            msg.header.stamp = self.get_clock().now().to_msg()
            self._diag_pub.publish(msg)
        except Exception as exc:  # noqa: BLE001
            self._internal_error(exc)
