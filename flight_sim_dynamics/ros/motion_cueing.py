"""The managed node ``motion_cueing``: a vehicle's motion in (``vehicle_imu``,
``sensor_msgs/Imu``), the platform's setpoints out (``pose_setpoint``,
``twist_setpoint``, ``accel_setpoint``, stamped, at ``cueing.rate``), through
the motion-cueing planner (:class:`..cueing.planner.Planner`: the washout and
the limiter on the machine). Nothing a client sends takes it down.
Topics, parameters, behaviour: docs/cueing_node.md.

    motion_cueing --ros-args --params-file config/<name>.yaml

The machine and the defaults of the ``cueing.*`` parameters come from the
dynamics node's parameter file (``params_file``, else the ``--params-file``
with a section for the dynamics node, else the default machine's packaged file).
"""
from __future__ import annotations

import argparse
import math
import sys
import time
from dataclasses import dataclass
from typing import Any, Mapping, Sequence

import numpy as np
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from rcl_interfaces.msg import SetParametersResult
from rclpy.clock import Clock, ClockType
from rclpy.lifecycle import LifecycleState, TransitionCallbackReturn
from rclpy.parameter import Parameter
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.qos_overriding_options import InvalidQosOverridesError, QoSOverridingOptions
from sensor_msgs.msg import Imu

from ..config import parameters as prm
from ..config.errors import did_you_mean
from ..config.files import NODE_NAME, QOS_OVERRIDES, params_files_in, read_params_sections
from ..config.machine_files import example_params_file, load_model
from ..config.schema import CUEING_NODE_NAME, CUEING_NODE_PARAMETERS, CUEING_TASK
from ..config.cueing import PARAMETER_SPECS, PREFIX, CueingParams, cueing_params_flat
from ..cueing.planner import Planner
from ..machines.api import machine_of
from .cueing_input import InputFeed
from .dynamics_node import QOS_POLICIES, check_qos, default_qos
from .node import executable_parser, run_managed
from .managed_node import ManagedNode
from .parameter_guard import _failed, plain
from .planner import SetpointPublisher
from .platform_sim import plant_file
from .process import end_spins, stop_requested
from .diagnostics import LogThrottle, diagnostic_name, number
from .join import RESTART_CONFIRMATIONS
from .messages import (ERROR, LEVEL_NAMES, NON_FINITE, OK, STAMP_BACKWARDS, STAMP_REPEATED, WARN,
                       SetpointError, fmt_stamp)

INACTIVE = 'inactive'                 # an Imu taken while the node is not active
OUT_OF_RANGE = 'out_of_range'         # beyond input.max_specific_force / max_angular_velocity
#: Why an Imu message is not used, in the order /diagnostics lists them.
REJECTION_REASONS = (NON_FINITE, OUT_OF_RANGE, STAMP_BACKWARDS, STAMP_REPEATED, INACTIVE)
#: Seconds between two log lines of one reason.
LOG_THROTTLE = 2.0
#: s of output samples made at once after a stall at most; the rest are skipped
#: (the motion stays continuous: the planner makes whole periods, the stamps
#: follow the clock)
MAX_CATCH_UP = 0.1
#: The platform is at neutral (a deferred parameter change takes over) when
#: every coordinate is within NEUTRAL_POSITION (m or rad) of home and every
#: rate within NEUTRAL_RATE (m/s or rad/s).
NEUTRAL_POSITION = 1e-4
NEUTRAL_RATE = 1e-3
_READ_ONLY = frozenset({'params_file', 'scene', 'autostart'})


def imu_qos() -> QoSProfile:
    """Best effort (matches sensor-data and reliable publishers alike), KEEP_LAST 100:
    only the newest message is used.
    """
    return QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=100,
                      reliability=ReliabilityPolicy.BEST_EFFORT)


@dataclass(frozen=True)
class CueingConfig:
    """The validated parameters: the planner's (``params``) and the node's."""

    params: CueingParams
    cueing: tuple[tuple[str, Any], ...]     # the cueing.* values the planner is built of
    timeout: float
    max_force: float
    max_rate: float
    frame_id: str
    diagnostics_period: float

    @classmethod
    def of(cls, values: Mapping[str, Any], source: str = '') -> 'CueingConfig':
        for spec in CUEING_NODE_PARAMETERS:
            prm.check_value(spec, values[spec.name])
        cueing = {k: v for k, v in values.items() if k.startswith(PREFIX)}
        return cls(cueing_params_flat(cueing, source),
                   tuple(sorted((k, tuple(v) if isinstance(v, list) else v)
                                for k, v in cueing.items())),
                   values['input.timeout'], values['input.max_specific_force'],
                   values['input.max_angular_velocity'], values['output.frame_id'],
                   values['diagnostics.period'])

    def with_planner_of(self, other: 'CueingConfig') -> 'CueingConfig':
        """This node's settings, ``other``'s planner parameters."""
        return CueingConfig(other.params, other.cueing, self.timeout, self.max_force,
                            self.max_rate, self.frame_id, self.diagnostics_period)


class InputStats:
    """Counters of the vehicle_imu messages and of the planner's output."""

    def __init__(self) -> None:
        self.received = self.accepted = self.restarts = 0
        self.rejected = {reason: 0 for reason in REJECTION_REASONS}
        self.last_rejection = ''
        self.published = self.steps = self.skipped = 0
        self.limited_total = 0
        self.limits: dict[str, int] = {}
        self.statuses: dict[str, int] = {}
        self.parameter_changes = self.parameter_rejections = 0
        self.internal_errors = self.non_finite_output = 0
        self.last_given_up = 0.0
        self.last_limit = ''
        self.new_period()

    def new_period(self) -> None:
        self.period_given_up = 0.0
        self.period_limited = 0
        self.period_steps: list[float] = []
        self._rejected_at_start = sum(self.rejected.values())
        self._skipped_at_start = self.skipped
        self._errors_at_start = self.internal_errors + self.non_finite_output
        self._not_ok_at_start = sum(v for k, v in self.statuses.items() if k != 'ok')

    def sample(self, given_up: float, limit: str, status: str, work: float) -> None:
        self.steps += 1
        self.period_steps.append(work)
        self.last_given_up, self.last_limit = given_up, limit
        if given_up > 0.0 or limit:
            self.limited_total += 1
            self.period_limited += 1
            self.period_given_up = max(self.period_given_up, given_up)
            if limit:
                self.limits[limit] = self.limits.get(limit, 0) + 1
        self.statuses[status] = self.statuses.get(status, 0) + 1

    def reject(self, reason: str, message: str) -> None:
        self.rejected[reason] += 1
        self.last_rejection = f'{reason}: {message}'

    def report(self) -> tuple[int, list[str], list[tuple[str, str]]]:
        """(level, problems, values) of this period; a new period starts."""
        rejected = sum(self.rejected.values()) - self._rejected_at_start
        skipped = self.skipped - self._skipped_at_start
        errors = self.internal_errors + self.non_finite_output - self._errors_at_start
        not_ok = sum(v for k, v in self.statuses.items() if k != 'ok') - self._not_ok_at_start
        problems = [text for show, text in (
            (errors, f'{errors} internal errors or non-finite samples'),
            (not_ok, f'{not_ok} samples not ok'),
            (rejected, f'{rejected} vehicle_imu messages rejected'),
            (skipped, f'{skipped} output samples skipped (late)')) if show]
        level = ERROR if errors or not_ok else WARN if problems else OK
        work = sorted(self.period_steps)
        n = len(work)
        values = [
            ('imu received', str(self.received)),
            ('imu accepted', str(self.accepted)),
            ('rejected total', str(sum(self.rejected.values()))),
            *((f'rejected {reason}', str(count)) for reason, count in self.rejected.items()),
            ('stream restarts', str(self.restarts)),
            ('last rejection', self.last_rejection),
            ('samples published', str(self.published)),
            ('planner steps', str(self.steps)),
            ('samples skipped', str(self.skipped)),
            ('given up last', f'{self.last_given_up:.3f}'),
            ('given up max this period', f'{self.period_given_up:.3f}'),
            ('samples limited this period', str(self.period_limited)),
            ('samples limited total', str(self.limited_total)),
            ('limit last', self.last_limit or 'none'),
            *((f'limit {name}', str(count)) for name, count in sorted(self.limits.items())),
            *((f'status {name}', str(count)) for name, count in sorted(self.statuses.items())),
            ('step time mean (us)', number(1e6 * sum(work) / n if n else math.nan, '.1f')),
            ('step time max (us)', number(1e6 * work[-1] if n else math.nan, '.1f')),
            ('parameter changes', str(self.parameter_changes)),
            ('parameter rejections', str(self.parameter_rejections)),
            ('non-finite samples (not sent)', str(self.non_finite_output)),
            ('internal errors', str(self.internal_errors)),
        ]
        self.new_period()
        return level, problems, values


class MotionCueingNode(ManagedNode):
    """Starts unconfigured; :meth:`start` (or a lifecycle manager) configures
    and activates it. ``params_files``: the ``--params-file`` files of its
    command line. :attr:`failure`: why configure failed.
    """

    REJECTED = 'parameter change rejected, planner unchanged'

    def __init__(self, params_files: Sequence[str] = (), **kwargs: Any) -> None:
        super().__init__(CUEING_NODE_NAME, **kwargs)
        self.stats = InputStats()
        self._throttle = LogThrottle(LOG_THROTTLE)
        self._steady = Clock(clock_type=ClockType.STEADY_TIME)
        self._diag_name = diagnostic_name(self.get_fully_qualified_name(), CUEING_TASK)
        self._config: CueingConfig | None = None     # None: unconfigured
        # validated by the on-set callback: the config and its planner (None: the same)
        self._staged: tuple[CueingConfig, Planner | None] | None = None
        self._planner: Planner | None = None
        self._next: tuple[CueingConfig, Planner] | None = None   # a change waiting for neutral
        self._feed: InputFeed | None = None
        self._active = False
        self._setpoints: SetpointPublisher | None = None
        self._imu_sub = self._diag_pub = self._diag_timer = self._timer = None
        given = self._given_parameters()
        # the dynamics node next to it: in its namespace
        self._dynamics = f"{self.get_namespace().rstrip('/')}/{NODE_NAME}"
        path_given = given.get('params_file')
        path = plain(path_given.value) if path_given is not None else ''
        path = plant_file(path if isinstance(path, str) else '', params_files, self._dynamics,
                          'params_file')
        source = path or "the default machine's packaged file"
        scene = plain(given['scene'].value) if 'scene' in given else ''
        scene = scene if isinstance(scene, str) else ''   # another type: refused below
        try:
            self.model = load_model(path, scene or None)
        except prm.SceneError as exc:
            raise prm.ParameterError('scene', scene, str(exc)) from None
        except prm.ParameterError:
            raise
        except (OSError, ValueError) as exc:
            raise prm.ParameterError('params_file', path, str(exc)) from None
        self.machine = machine_of(self.model)
        # the dynamics node's section (load_model checked its cueing group)
        flat = read_params_sections(path, self._dynamics) if path else {}
        defaults = {s.name: s.default for s in CUEING_NODE_PARAMETERS + PARAMETER_SPECS}
        defaults.update((k, v) for k, v in flat.items() if k.startswith(PREFIX))
        defaults['params_file'] = path or ''
        defaults['scene'] = self.model.scene
        self._source = source
        self._specs = {s.name: s for s in CUEING_NODE_PARAMETERS + PARAMETER_SPECS}
        # the machine's own parameters reach this node too under a '/**' section;
        # any other name it does not know (a typo) ends the start, as a file's does
        # for the dynamics node
        for name, param in given.items():
            if name not in self._specs and name not in flat \
                    and not name.startswith(QOS_OVERRIDES):
                raise prm.ParameterError(name, plain(param.value), (
                    f'not a parameter of {CUEING_NODE_NAME}' + did_you_mean(name, self._specs)))
        self._refused = self._declare_specs(list(self._specs.values()), defaults, given,
                                            lambda name: name in _READ_ONLY)
        self._guard_services()
        self.add_on_set_parameters_callback(self._on_set_parameters)
        self.add_post_set_parameters_callback(self._on_parameters_set)

    # -- parameters ----------------------------------------------------------------
    def _values(self) -> dict[str, Any]:
        return {name: plain(self.get_parameter(name).value) for name in self._specs
                if self.has_parameter(name)}

    def _on_set_parameters(self, params: list[Parameter]) -> SetParametersResult:
        """Validate the whole set as it would be, the planner built; staged for the commit."""
        ours = [p for p in params if p.name in self._specs]
        if not ours:
            return SetParametersResult(successful=True)
        self._staged = None
        try:
            if self._config is None:    # unconfigured: each on its own; configure checks all
                reason = next(filter(None, (self._check(p, self._specs[p.name]) for p in ours)),
                              None)
                return _failed(reason) if reason else SetParametersResult(successful=True)
            values = self._values()
            values.update((p.name, plain(p.value)) for p in ours)
            config = CueingConfig.of(values, 'the parameters')
            planner = Planner(self.model, config.params) \
                if config.cueing != self._config.cueing else None     # it must build
            self._staged = (config, planner)
            return SetParametersResult(successful=True)
        except prm.ParameterError as exc:
            reason = str(exc)
        except Exception as exc:  # noqa: BLE001 - e.g. a planner that refuses the values
            reason = f'{type(exc).__name__}: {exc}'
        self._staged = None
        self._refused_by_callback()
        self.get_logger().warn(f'{self.REJECTED}: {reason}')
        return _failed(reason)

    def _on_parameters_set(self, params: list[Parameter]) -> None:
        try:
            for p in params:
                self._refused.pop(p.name, None)
            staged, self._staged = self._staged, None
            if staged is None or self._config is None:
                return
            staged, planner = staged
            self.stats.parameter_changes += 1
            old = self._config
            names = ', '.join(dict.fromkeys(p.name for p in params))
            if planner is not None:
                # the planner's state is not carried over: the running one washes the
                # platform out to neutral, then the new one takes over (no jump)
                self._next = (staged, planner)
                self._config = staged.with_planner_of(old)
                self.get_logger().info(f'parameters changed: {names}; the new planner takes '
                                       'over once the platform is at neutral')
            else:
                # the running planner's values (again): a change still waiting is void
                self._config, self._next = staged, None
                self.get_logger().info(f'parameters changed: {names}')
            self._apply_node_config(self._config)
            self._hand_over()
        except Exception as exc:  # noqa: BLE001
            self._internal_error(exc)

    def _apply_node_config(self, config: CueingConfig) -> None:
        if self._feed is not None:
            self._feed.timeout = config.timeout
        if self._setpoints is not None:
            self._setpoints.frame_id = config.frame_id
        if self._diag_timer is not None:
            self._diag_timer.timer_period_ns = int(config.diagnostics_period * 1e9)

    def _count_refused(self, count: int) -> None:
        self.stats.parameter_rejections += count

    def _read_only_reason(self, name: str) -> str | None:
        if name not in _READ_ONLY:
            return None
        return (f"parameter '{name}' is read-only: refused; it is fixed at start-up (another "
                'machine or start-up needs another node)')

    # -- lifecycle (ManagedNode: start, configure's failure, cleanup, shutdown) ---
    def _configure(self) -> None:
        config = CueingConfig.of(self._values(), self._source)
        self._planner = Planner(self.model, config.params)
        self._config = config
        self._next = None
        self._reset_motion()
        self._create_endpoints(config)

    def _configured(self) -> None:
        dropped = ', '.join(getattr(self._planner, 'dropped', ())) or 'none'
        p = self._config.params
        self.get_logger().info(
            f'configured: {self.machine.title} ({self._source}, scene {self.model.scene}), '
            f'{p.rate:g} Hz, limiter '
            f'{p.limiter}; channels not cued: {dropped}; vehicle_imu in, pose/twist/'
            'accel_setpoint out, /diagnostics')

    def on_activate(self, state: LifecycleState) -> TransitionCallbackReturn:
        self._reset_motion()
        self._active = True
        self._start_timer(self._config.params.rate)
        self.get_logger().info('active: cueing (the platform at neutral until the first '
                               'vehicle_imu)')
        return super().on_activate(state)

    def on_deactivate(self, state: LifecycleState) -> TransitionCallbackReturn:
        self._active = False
        self._stop_timer()
        self.get_logger().info('inactive: no setpoints; vehicle_imu counted, not used')
        return super().on_deactivate(state)

    def destroy_node(self) -> None:
        self._stop_serving_apart()
        super().destroy_node()

    def _create_endpoints(self, config: CueingConfig) -> None:
        options = QoSOverridingOptions(QOS_POLICIES, callback=check_qos)
        try:
            self._setpoints = SetpointPublisher(
                self, self.machine, config.frame_id, default_qos(),
                create=lambda *a: self.create_publisher(*a, qos_overriding_options=options))
            self._imu_sub = self.create_subscription(Imu, 'vehicle_imu', self._on_imu,
                                                     imu_qos(), qos_overriding_options=options)
        except (InvalidQosOverridesError, RuntimeError, AssertionError, TypeError,
                ValueError) as exc:
            raise prm.ParameterError(QOS_OVERRIDES + '*', None,
                                     f'invalid QoS override: {exc}') from None
        self._diag_pub = self.create_publisher(DiagnosticArray, '/diagnostics', 10)
        self._diag_timer = self.create_timer(config.diagnostics_period, self._on_diagnostics,
                                             clock=self._steady)

    def _release(self) -> None:
        self._active = False
        self._stop_timer()
        if self._diag_timer is not None:
            self.destroy_timer(self._diag_timer)
        if self._setpoints is not None:
            for pub in self._setpoints.publishers:
                self.destroy_publisher(pub)
        if self._imu_sub is not None:
            self.destroy_subscription(self._imu_sub)
        if self._diag_pub is not None:
            self.destroy_publisher(self._diag_pub)
        self._setpoints = None
        self._imu_sub = self._diag_pub = self._diag_timer = None
        self._config = self._staged = self._next = None
        self._planner = None

    # -- the motion ------------------------------------------------------------------
    def _reset_motion(self) -> None:
        """At neutral, waiting for a first input (it becomes the planner's rest)."""
        self._planner.reset()
        self._feed = InputFeed(self._config.params.rate, self._config.timeout)
        self._arrival = -math.inf          # monotonic time of the newest input
        self._last_stamp: int | None = None
        self._behind = 0
        self._q = np.zeros(self.machine.dof)       # the last sample out
        self._qd = np.zeros(self.machine.dof)

    def _anchor(self, rate: float, stamp0: int) -> None:
        """Sample k from now on is due k / rate s from now, stamped stamp0 + k / rate."""
        self._period_ns = round(1e9 / rate)
        self._k = 0
        self._wall0 = time.monotonic()
        self._stamp0 = stamp0
        self._max_catch_up = max(1, int(MAX_CATCH_UP * rate))

    def _start_timer(self, rate: float) -> None:
        self._stop_timer()
        self._anchor(rate, self.get_clock().now().nanoseconds)
        self._timer = self.create_timer(1.0 / rate, self._on_tick, clock=self._steady)

    def _stop_timer(self) -> None:
        if self._timer is not None:
            self.destroy_timer(self._timer)
            self._timer = None

    def input_state(self) -> str:
        if not self._active:
            return 'inactive'
        if self._feed.rest is None:
            return 'waiting for vehicle_imu'
        return 'stale' if self._stale() else 'live'

    def _stale(self) -> bool:
        return time.monotonic() - self._arrival > self._config.timeout

    def _at_neutral(self) -> bool:
        return (float(np.max(np.abs(self._q), initial=0.0)) <= NEUTRAL_POSITION
                and float(np.max(np.abs(self._qd), initial=0.0)) <= NEUTRAL_RATE)

    def _hand_over(self) -> bool:
        """The waiting planner takes over if the platform is at neutral (or not
        driven: inactive, or no input since the activation); True if it did.
        """
        if self._next is None or not (not self._active or self._feed.rest is None
                                      or self._at_neutral()):
            return False
        config, planner = self._next
        self._next = None
        old_rate = self._config.params.rate
        self._config, self._planner = config, planner
        self._apply_node_config(config)
        rate = config.params.rate
        # the new planner's rest: the first input arriving from now on
        self._feed = InputFeed(rate, config.timeout)
        if rate != old_rate and self._timer is not None:
            # the stamps go on from the last one sent, at the new period
            following = self._stamp0 + (self._k - 1) * self._period_ns + round(1e9 / rate) \
                if self._k else self.get_clock().now().nanoseconds
            self._anchor(rate, following)
            self._timer.timer_period_ns = self._period_ns
        self._info(f'the new planner took over ({rate:g} Hz, limiter {config.params.limiter})')
        return True

    def _on_tick(self) -> None:
        try:
            if not self._active or self._planner is None:
                return
            if self._next is not None and self._hand_over():
                return          # re-anchored: the next tick makes the samples due
            due = int((time.monotonic() - self._wall0) * 1e9 / self._period_ns) + 1
            todo = due - self._k
            if todo > self._max_catch_up:
                self.stats.skipped += todo - self._max_catch_up
                self._k += todo - self._max_catch_up
                todo = self._max_catch_up
            for _ in range(max(todo, 0)):
                if stop_requested():
                    end_spins()
                    return
                self._step()
                self._k += 1
        except Exception as exc:  # noqa: BLE001 - nothing escapes a callback
            self._internal_error(exc)

    def _step(self) -> None:
        """One output sample: the planner fed the input (:class:`.cueing_input.InputFeed`:
        toward the newest message, or toward the rest when the input is stale or a
        parameter change waits); published.
        """
        stamp = self._stamp0 + self._k * self._period_ns
        fed = self._feed.next(want_rest=self._next is not None or self._stale())
        if fed is None:                     # at neutral, waiting for a first input
            zero = np.zeros(self.machine.dof)
            self._send(stamp, zero, zero, zero)
            return
        start = time.perf_counter()
        sample = self._planner.step(fed[:3], fed[3:])
        work = time.perf_counter() - start
        q, qd, qdd = (np.asarray(v, dtype=float) for v in (sample.q, sample.qd, sample.qdd))
        if not (np.isfinite(q).all() and np.isfinite(qd).all() and np.isfinite(qdd).all()):
            # never sent: the dynamics node would refuse it; the platform keeps the last one
            self.stats.non_finite_output += 1
            self._error('non_finite_output', 'the planner gave a non-finite sample: not '
                        'published (deactivate and activate to start afresh)')
            return
        self._q, self._qd = q, qd
        self.stats.sample(float(sample.given_up), str(sample.limit), str(sample.status), work)
        self._send(stamp, q, qd, qdd)

    def _send(self, stamp: int, q: Any, qd: Any, qdd: Any) -> None:
        try:
            self._setpoints.send(stamp, q, qd, qdd)
            self.stats.published += 1
        except Exception:
            if self.context.ok():
                raise
            return          # shutting down: the shutdown's failure

    # -- the vehicle's motion in -----------------------------------------------------
    def _on_imu(self, msg: Imu) -> None:
        if stop_requested():        # stopping: the spin returns after this callback
            end_spins()
            return
        stats = self.stats
        try:
            stats.received += 1
            try:
                if not self._active:
                    raise SetpointError(INACTIVE, 'the node is not active')
                a, w = msg.linear_acceleration, msg.angular_velocity
                f = np.array((a.x, a.y, a.z), dtype=float)
                omega = np.array((w.x, w.y, w.z), dtype=float)
                if not (np.all(np.isfinite(f)) and np.all(np.isfinite(omega))):
                    raise SetpointError(NON_FINITE, f'linear_acceleration {f.tolist()}, '
                                                    f'angular_velocity {omega.tolist()}')
                config = self._config
                if np.abs(f).max() > config.max_force or np.abs(omega).max() > config.max_rate:
                    raise SetpointError(OUT_OF_RANGE, (
                        f'linear_acceleration {f.tolist()} m/s^2, angular_velocity '
                        f'{omega.tolist()} rad/s: beyond input.max_specific_force = '
                        f'{config.max_force:g} or input.max_angular_velocity = '
                        f'{config.max_rate:g}'))
                stamp = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec
                self._check_stamp(stamp)
            except SetpointError as exc:
                stats.reject(exc.reason, str(exc))
                if exc.reason != INACTIVE:
                    self._warn(exc.reason, f'vehicle_imu rejected ({exc.reason}): {exc}')
                return
            stats.accepted += 1
            self._feed.receive(np.concatenate((f, omega)), stamp)
            self._arrival = time.monotonic()
        except Exception as exc:  # noqa: BLE001
            self._internal_error(exc)

    def _check_stamp(self, stamp: int) -> None:
        """Stamps in order; a repeated one dropped; :data:`RESTART_CONFIRMATIONS`
        in a row before the last accepted one: the vehicle's clock restarted.
        """
        last = self._last_stamp
        if last is not None and stamp <= last:
            self._behind += 1
            if self._behind < RESTART_CONFIRMATIONS:
                if stamp == last:
                    raise SetpointError(STAMP_REPEATED, f'stamp {fmt_stamp(stamp)} repeated')
                raise SetpointError(STAMP_BACKWARDS, f'stamp {fmt_stamp(stamp)} before the '
                                                     f'last accepted one ({fmt_stamp(last)})')
            self.stats.restarts += 1
            self._info(f'vehicle_imu stamps restarted at {fmt_stamp(stamp)}: accepted')
        self._behind = 0
        self._last_stamp = stamp

    # -- reports -----------------------------------------------------------------------
    # rclpy fixes a severity per call site: one call site per severity
    def _warn(self, key: str, text: str) -> None:
        skipped = self._throttle(key, time.monotonic())
        if skipped is not None:
            self.get_logger().warn(text + (f' ({skipped} more since the last line)'
                                           if skipped else ''))

    def _error(self, key: str, text: str) -> None:
        skipped = self._throttle(key, time.monotonic())
        if skipped is not None:
            self.get_logger().error(text + (f' ({skipped} more since the last line)'
                                            if skipped else ''))

    def _info(self, text: str) -> None:
        self.get_logger().info(text)

    def _internal_error(self, exc: Exception) -> None:
        if not self.context.ok():       # shutting down: the shutdown's failure
            return
        self.stats.internal_errors += 1
        self._error('internal', f'internal error (the node carries on): '
                                f'{type(exc).__name__}: {exc}')

    def _on_diagnostics(self) -> None:
        try:
            config = self._config
            if config is None:          # a tick queued before cleanup
                return
            level, problems, values = self.stats.report()
            state = self.input_state()
            message = '; '.join(problems) if problems else {
                'inactive': 'inactive', 'waiting for vehicle_imu': 'waiting for vehicle_imu',
                'stale': 'input stale: washing out to neutral', 'live': 'OK'}[state]
            if self._next is not None:
                message += '; new parameters wait for neutral'
            p = config.params
            values[:0] = [
                ('status', LEVEL_NAMES[level]),
                ('lifecycle state', 'active' if self._active else 'inactive'),
                ('machine', self.machine.title),
                ('limiter', p.limiter),
                ('rate (Hz)', f'{p.rate:g}'),
                ('input', state),
                ('input timeout (s)', f'{config.timeout:g}'),
                ('channels not cued', ', '.join(getattr(self._planner, 'dropped', ())) or 'none'),
                ('parameter change pending', 'yes (waits for neutral)' if self._next else 'no'),
            ]
            msg = DiagnosticArray(status=[DiagnosticStatus(
                level=bytes([level]), name=self._diag_name, message=message,
                hardware_id=CUEING_NODE_NAME, values=[KeyValue(key=k, value=v)
                                                      for k, v in values])])
            msg.header.stamp = self.get_clock().now().to_msg()
            self._diag_pub.publish(msg)
        except Exception as exc:  # noqa: BLE001
            self._internal_error(exc)


# -- the executable ------------------------------------------------------------------
def build_parser() -> argparse.ArgumentParser:
    return executable_parser(
        'motion_cueing',
        'ROS 2 motion-cueing node of flight_sim_dynamics: vehicle_imu (sensor_msgs/Imu: '
        'specific force and angular velocity of the vehicle) in; pose/twist/accel_setpoint '
        'of the platform (for dynamics_node) and /diagnostics out. The machine: the '
        "dynamics node's --params-file (its cueing group gives the defaults). ROS arguments "
        f'go after --ros-args, e.g. --ros-args --params-file {example_params_file()} '
        '-p cueing.rate:=500.0',
        'See docs/cueing_node.md for topics, parameters and behaviour.')


def main(argv: Sequence[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    return run_managed('motion_cueing', build_parser(), argv,
                       lambda: MotionCueingNode(params_files_in(argv)))

if __name__ == '__main__':
    sys.exit(main())
