"""The twin node's rules without ROS: its parameters as a stepper, the check
of one command, the real-time bookkeeping and the /diagnostics report of
``platform_sim`` (:mod:`.platform_sim`).

A command is a ``sensor_msgs/JointState`` in the layout ``dynamics_node``
publishes on ``actuator_states`` (:data:`..core.model.LEG_NAMES`; position =
leg length reference, velocity = rate reference, effort = feed-forward
force): the three legs in any order, positions required, velocity and effort
either three numbers or empty (zero). Every rejection has a reason and is
counted; nothing of a rejected command reaches the servos.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Mapping, Sequence

from ..config import parameters as prm
from ..config.schema import SIM_PARAMETERS
from ..core.model import LEG_NAMES, Model
from ..core.simulation import Servo
from ..core.twin import TwinStepper
from .diagnostics import ERROR, LEVEL_NAMES, OK, WARN, number
from .inputs import NON_FINITE, STAMP_BACKWARDS, STAMP_REPEATED, SetpointError

BAD_NAMES = 'bad_names'          # names that are not the three legs, once each
BAD_SIZE = 'bad_size'            # an array of another size than 3 (or 0: velocity, effort)
#: Why a command is rejected, in the order /diagnostics lists them.
COMMAND_REASONS = (BAD_NAMES, BAD_SIZE, NON_FINITE, STAMP_REPEATED, STAMP_BACKWARDS)
#: Commands in a row stamped before the last accepted one that are a restart
#: of the stream (a planner restarted with its clock): accepted from then on.
RESTART_AFTER = 3
#: The status name of the twin in /diagnostics (``<node>: <task>``).
SIM_TASK = 'platform simulation'
SIM_SPECS: Mapping[str, prm.ParamSpec] = {spec.name: spec for spec in SIM_PARAMETERS}

Vec3 = tuple[float, float, float]


@dataclass(frozen=True)
class SimConfig:
    """The twin's validated parameters, the plant and its servos."""

    values: Mapping[str, Any]
    plant: Model
    servo: Servo

    @property
    def step(self) -> float:
        return 1.0 / self.values['rate']

    def stepper(self) -> TwinStepper:
        return TwinStepper(self.plant, self.servo, self.step, self.values['initial'])


def sim_config(values: Mapping[str, Any]) -> SimConfig:
    """Check every twin parameter (dotted names, defaults for the absent ones)
    and build the plant (:func:`..config.parameters.load_model`) and its
    servos; raises ParameterError (also for a plant scene without inertia or
    a start pose the plant cannot take).
    """
    checked = {name: prm.check_value(spec, values.get(name, spec.default))
               for name, spec in SIM_SPECS.items()}
    try:
        plant = prm.load_model(checked['plant.params_file'] or None,
                               checked['plant.scene'] or None)
    except prm.SceneError as exc:
        raise prm.ParameterError('plant.scene', checked['plant.scene'], str(exc)) from None
    except (OSError, ValueError) as exc:
        raise prm.ParameterError('plant.params_file', checked['plant.params_file'],
                                 str(exc)) from None
    if checked['tick_rate'] > checked['rate']:
        raise prm.ParameterError('tick_rate', checked['tick_rate'],
                                 f"must not exceed rate ({checked['rate']:g} Hz): a tick "
                                 'makes whole steps')
    try:
        servo = Servo.for_bandwidth(plant, checked['servo.bandwidth'], checked['servo.damping'])
        config = SimConfig(checked, plant, servo)
        twin = config.stepper()
    except ValueError as exc:           # a scene without inertia
        raise prm.ParameterError('plant.scene', checked['plant.scene'], str(exc)) from None
    if not twin.running:
        raise prm.ParameterError('initial', checked['initial'],
                                 f'the plant cannot start there: {twin.outcome}: {twin.detail}')
    return config


def check_command(names: Sequence[str], position: Sequence[float],
                  velocity: Sequence[float], effort: Sequence[float]
                  ) -> tuple[Vec3, Vec3, Vec3]:
    """(length, rate, force) of a command, legs A, B, C; raises
    :class:`SetpointError` with the reason (:data:`COMMAND_REASONS`; the
    stamp is checked by :meth:`CommandStats.stamp`).
    """
    if len(names) != 3 or sorted(names) != sorted(LEG_NAMES):
        raise SetpointError(BAD_NAMES, f'names must be {", ".join(LEG_NAMES)} once each, '
                                       f'got {list(names)!r:.200}')
    if len(position) != 3:
        raise SetpointError(BAD_SIZE, f'position must have 3 values, got {len(position)}')
    for what, values in (('velocity', velocity), ('effort', effort)):
        if len(values) not in (0, 3):
            raise SetpointError(BAD_SIZE, f'{what} must have 3 values or none, '
                                          f'got {len(values)}')
    order = [names.index(leg) for leg in LEG_NAMES]
    out = []
    for what, values in (('position', position), ('velocity', velocity), ('effort', effort)):
        if not values:
            out.append((0.0, 0.0, 0.0))
            continue
        picked = (float(values[order[0]]), float(values[order[1]]), float(values[order[2]]))
        if not all(math.isfinite(v) for v in picked):
            raise SetpointError(NON_FINITE, f'{what} has a non-finite value {picked!r}')
        out.append(picked)
    return out[0], out[1], out[2]


class CommandStats:
    """Counters of the commands, stamp order, and the real-time figures of
    the loop (per diagnostics period: ticks, their work time, simulated time).
    """

    def __init__(self) -> None:
        self.received = 0
        self.accepted = 0
        self.rejected = {reason: 0 for reason in COMMAND_REASONS}
        self.restarts = 0
        self.last_rejection = ''
        self.last_stamp: int | None = None
        self._behind = 0
        self.overruns = 0                    # ticks late or with dropped steps, total
        self.dropped_steps = 0
        self.non_finite_outputs = 0          # states not published (never seen: a guard)
        self._period_reset(None, 0.0)

    def _period_reset(self, now: float | None, sim_time: float) -> None:
        self._start, self._sim_start = now, sim_time
        self._work: list[float] = []
        self._rejected_at_start = sum(self.rejected.values())
        self._overruns_at_start = self.overruns

    def stamp(self, stamp_ns: int) -> None:
        """Accept a command's stamp, or raise SetpointError (repeated, or
        before the last accepted one; :data:`RESTART_AFTER` in a row are a
        restart, accepted).
        """
        last = self.last_stamp
        if last is not None and stamp_ns <= last:
            self._behind += 1
            if self._behind < RESTART_AFTER:
                if stamp_ns == last:
                    raise SetpointError(STAMP_REPEATED, f'stamp {stamp_ns} ns repeated')
                raise SetpointError(STAMP_BACKWARDS, f'stamp {stamp_ns} ns before the last '
                                                     f'accepted one ({last} ns)')
            self.restarts += 1
        self._behind = 0
        self.last_stamp = stamp_ns

    def reject(self, reason: str, message: str) -> None:
        self.rejected[reason] += 1
        self.last_rejection = f'{reason}: {message}'

    def tick(self, work: float, period: float, dropped: int) -> None:
        """One tick of the loop: its work time (s) against its period; steps
        it had to drop.
        """
        self._work.append(work)
        if dropped or work > period:
            self.overruns += 1
            self.dropped_steps += dropped

    def report(self, now: float, twin: TwinStepper, started: bool, rate: float
               ) -> tuple[int, str, list[tuple[str, str]]]:
        """(level, message, [(key, value), ...]) for this period; starts a new
        one. ERROR once the plant stopped; WARN for rejections, overruns or a
        plant beyond an actuator limit this period.
        """
        wall = now - self._start if self._start is not None else math.nan
        simulated = twin.time - self._sim_start
        factor = simulated / wall if started and wall > 0 else math.nan
        work = sorted(self._work)
        n = len(work)
        rejected = sum(self.rejected.values()) - self._rejected_at_start
        overruns = self.overruns - self._overruns_at_start
        problems = []
        level = OK
        if not twin.running:
            level, problems = ERROR, [f'stopped: {twin.outcome}: {twin.detail}']
        else:
            if rejected:
                problems.append(f'{rejected} commands rejected')
            if overruns:
                problems.append(f'{overruns} overruns')
            if str(twin.status) != 'ok':
                problems.append(f'plant {twin.status}: {twin.status_detail}')
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
            ('rejected total', str(sum(self.rejected.values()))),
        ]
        values += [(f'rejected {reason}', str(count)) for reason, count in self.rejected.items()]
        values += [('stream restarts', str(self.restarts)),
                   ('non-finite states not published', str(self.non_finite_outputs)),
                   ('last rejection', self.last_rejection)]
        self._period_reset(now, twin.time)
        return level, message, values
