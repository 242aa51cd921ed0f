"""What the shared layer (the public API, configuration, command line) needs
from a machine: :class:`Machine`, one per kind of model, and the error a
machine's model builder raises for a bad parameter.

Each machine implements the same calls on its own model type, with vectors of
``len(coordinates)`` pose numbers and ``len(legs)`` actuator numbers:

=================================================  ===============================
``solve(model, q, qd, qdd)``                       one sample: lengths, forces, status
``solve_batch(model, Q, Qd, Qdd)``                 N samples, arrays (N, dof)
``forward_kinematics(model, lengths, initial=0)``  the pose of given leg lengths
                                                   (:func:`check_forward_options`)
``forward_dynamics(model, q, qd, force)``          accelerations of given forces
``actuator_limits(model)``                         strokes, speed and force allowed
``limit_usage(model, solution)``                   how much of each limit it uses
                                                   (:class:`LimitUsage`)
``tightened(model, stroke, fraction)``             the model within margins of its
                                                   limits (:func:`narrowed_limits`)
=================================================  ===============================

The home pose is q = 0 for every machine (poses are measured from it).
Each machine brings its parameters: their names and declarations
(:attr:`Machine.parameters`, :attr:`Machine.parameter_specs`) and the model
builder of a file's values (:attr:`Machine.from_params`).
"""
from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field, fields, replace
from typing import Any, Callable, Mapping

import numpy as np

from .drawing import Drawing
from .effects import EFFECT_NAMES
from .motion import Motion
from .parameter_spec import ModelValueError, ParamSpec
from .workspace import Option, Survey

__all__ = ['ActuatorLimits', 'LimitUsage', 'Machine', 'ModelValueError', 'check_forward_options',
           'narrowed_limits', 'quiet_floating_point', 'stroke_usage']


def check_forward_options(tolerance: float, max_iterations: int) -> None:
    """The options of every machine's ``forward_kinematics``: ValueError for a
    ``tolerance`` (m, on max |L(q) - L*|) that is not a finite number > 0 and for
    ``max_iterations`` that is not an integer >= 1 (a bool is not one).
    """
    if (isinstance(tolerance, bool) or not isinstance(tolerance, (int, float, np.floating,
                                                                   np.integer))
            or not (math.isfinite(tolerance) and tolerance > 0)):
        raise ValueError(f'tolerance must be a finite number > 0 (m), got {tolerance!r:.80}')
    if (isinstance(max_iterations, (bool, np.bool_))
            or not isinstance(max_iterations, (int, np.integer)) or max_iterations < 1):
        raise ValueError(f'max_iterations must be an integer >= 1, got {max_iterations!r:.80}')


def narrowed_limits(limits: Any, ends: tuple[str, str], scaled: tuple[str, ...],
                    stroke: float, fraction: float, fixed: tuple[str, ...] = ()) -> Any:
    """A copy of the limits dataclass ``limits`` within margins of them (a
    planner's, cueing/limiter.py): the range ``ends`` (the fields of the lowest
    and highest stroke or length) ``stroke`` inside each end, each field of
    ``scaled`` (upper bounds: speed, force, conditions, joint angles) times
    ``1 - fraction``, ``fixed`` and unset (None) fields as they are.
    ValueError for a field of none of them (a new limit must be given its
    margin) and for a stroke margin that leaves no travel.
    """
    low, high = ends
    changes: dict[str, float] = {}
    for f in fields(limits):
        name, value = f.name, getattr(limits, f.name)
        if name in fixed or value is None:
            continue
        if name == low:
            changes[name] = value + stroke
        elif name == high:
            changes[name] = value - stroke
        elif name in scaled:
            changes[name] = value * (1.0 - fraction)
        else:
            raise ValueError(f'no margin for the limit {name!r}')
    if not changes[low] < changes[high]:
        raise ValueError(f'a stroke margin of {stroke:g} m leaves no travel '
                         f'({changes[low]:g} >= {changes[high]:g})')
    return replace(limits, **changes)


def quiet_floating_point(function: Callable[..., Any]) -> Callable[..., Any]:
    """``function`` with numpy's floating-point warnings off: a machine's call
    whose status judges numbers that overflow (e.g. leg lengths of 1e308) warns
    nobody through numpy (a RuntimeWarning naming numpy's source lines).
    """
    @functools.wraps(function)
    def quiet(*args: Any, **kwargs: Any) -> Any:
        with np.errstate(all='ignore'):
            return function(*args, **kwargs)
    return quiet


@dataclass(frozen=True)
class ActuatorLimits:
    """What each actuator may do without the status ``limit``, per leg."""

    stroke_min: np.ndarray   # (legs,) m, lowest stroke (length - length at home)
    stroke_max: np.ndarray   # (legs,) m, highest stroke
    max_speed: float         # m/s, largest |dL/dt|
    max_force: float         # N, largest |f|


@dataclass(frozen=True)
class LimitUsage:
    """How much of each of its limits a solution uses: ``usage[..., k]`` of the
    limit ``names[k]`` (``'stroke A'``, ``'speed 1'``, ``'u_joint 1'``: what,
    then the leg's label in upper case). Above 1: exceeded, which is
    the status ``limit`` of a sample that is otherwise ok; 1: at the limit.

    A leg's stroke usage is its distance from mid-stroke over half the
    stroke; speed, force and a joint angle: the value's magnitude over its
    maximum. ``usage`` is (len(names),) for one sample, (N, len(names)) for a batch.
    """

    names: tuple[str, ...]
    usage: np.ndarray

    @property
    def exceeded(self) -> bool | np.ndarray:
        """Whether some limit is exceeded: a bool, or (N,) bools for a batch."""
        over = (self.usage > 1.0).any(axis=-1)
        return bool(over) if over.ndim == 0 else over


def stroke_usage(value: Any, low: float, high: float, xp: Any = np) -> Any:
    """Distance of ``value`` from the middle of [low, high] over half the range:
    each side over its own half, so that either end uses exactly 1 (the
    status rules allow a value at its limit). ``xp``: numpy, or a machine's
    float backend (``where``) for plain floats.
    """
    middle = 0.5 * (low + high)
    return xp.where(value >= middle, (value - middle) / (high - middle),
                    (middle - value) / (middle - low))


@dataclass(frozen=True)
class Machine:
    """One kind of machine: its names and its calls (module docstring)."""

    name: str                            # the machine's kind (its entry point's name)
    model_type: type                     # the model class its calls take
    coordinates: tuple[str, ...]         # pose coordinates, in the order of q
    units: tuple[str, ...]               # their units ('m' or 'rad')
    legs: tuple[str, ...]                # actuated legs, in the order of forces
    joints: tuple[str, ...]              # joint variables, in the order of joint_states
    solve: Callable[..., Any]
    solve_batch: Callable[..., Any]
    forward_kinematics: Callable[..., Any]
    forward_dynamics: Callable[..., Any]
    actuator_limits: Callable[[Any], ActuatorLimits]
    # ``limit_usage(model, solution) -> LimitUsage``: one sample or a batch; the
    # rule of its solutions' status ``limit`` (usage > 1), the dynamics node's too
    limit_usage: Callable[[Any, Any], LimitUsage]
    # ``tightened(model, stroke, fraction) -> model``: the model whose limits keep
    # a planner's margins free (:func:`narrowed_limits`; the cueing limiter solves
    # on it); None: no margins, no limiter for the machine
    tightened: Callable[[Any, float, float], Any] | None = None
    # Its parameter files (a file names its machine, ``machine: <name>``; the
    # default machine's name none): the names they may give (dotted) and the
    # model of a file's nested parameters with a scene's effects,
    # ``from_params(params, effects) -> model`` (ModelValueError); the packaged
    # files (config/<name>.yaml) of its kind.
    parameters: frozenset[str] = frozenset()
    from_params: Callable[..., Any] | None = None
    parameter_files: tuple[str, ...] = ()
    # Names of the command line (cli/): a title for messages and figures; each
    # leg's label in column names (``force_<label>``) and legends; the scalar
    # fields of a solution that ``solve`` writes after the per-leg ones, and
    # those it writes on request only (``--cond``: costly).
    title: str = ''
    leg_labels: tuple[str, ...] = ()
    sample_fields: tuple[str, ...] = ()
    costly_fields: tuple[str, ...] = ()
    # Built-in motions (cli/ example and simulate --motion, benchmarks): name ->
    # Motion (motion.trajectory(t) -> q, qd, qdd, each (N, dof); motion.duration
    # s; motion.sampled(rate_hz) -> t, q, qd, qdd); the names ``example`` offers.
    motions: Mapping[str, Motion] = field(default_factory=dict, hash=False)
    examples: tuple[str, ...] = ()
    # The published figures an example's forces and powers compare with (plot's
    # default title): example name -> e.g. "the paper's Figs. 3 and 4".
    example_figures: Mapping[str, str] = field(default_factory=dict, hash=False)
    # What a user sees beyond numbers (animate, workspace; RViz markers):
    # ``drawing(model) -> Drawing`` (core/drawing.py); ``workspace(model, *,
    # resolution, **options) -> Survey`` (core/workspace.py: ranges, maps at
    # rest, checks of motions), its keywords ``workspace_options`` (given as
    # command-line options; not given: the function's defaults); None: no
    # workspace command for the machine.
    drawing: Callable[[Any], Drawing] | None = None
    workspace: Callable[..., Survey] | None = None
    workspace_options: tuple[Option, ...] = ()
    # What each effect costs (cli/bench.py): the effects the machine models
    # (core/effects.py; others have nothing to act on), the built-in motions
    # bench measures force errors on (the most demanding last), and whether its
    # compiled kernel runs (``kernel_enabled()``).
    effects: tuple[str, ...] = EFFECT_NAMES
    bench_motions: tuple[str, ...] = ()
    kernel_enabled: Callable[[], bool] = bool
    # Simulation and the twin (core/simulation.py, core/twin.py). The affine terms of
    # the inverse dynamics f = M(q) qdd + b(q, qd): ``affine_terms(model, q, qd) ->
    # (M (dof, dof), b (legs,), the solve at qdd = 0)`` (M, b zeros where that solve is
    # void; the solve gives length, rate, jacobian dL/dq, status, detail);
    # ``require_inertia(model)``: ValueError for a scene whose forces do not determine
    # accelerations; the kernel's RK4 of a tabulated force law, ``integrate_rows(model,
    # law, step, k0, steps, rows) -> the first row not completed`` (None: no kernel
    # loop), used while ``kernel_enabled()`` (the default, ``bool()``: never).
    affine_terms: Callable[..., tuple[np.ndarray, np.ndarray, Any]] | None = None
    require_inertia: Callable[[Any], None] | None = None
    integrate_rows: Callable[..., int] | None = None
    # The dynamics node (ros/): the declarations of the parameters its files give
    # (type, unit, meaning, the bounds its builder checks), and the pose
    # components outside ``coordinates`` that the machine moves by itself, each a
    # function of a solution (a setpoint giving that value is not reported as
    # motion the machine cannot follow).
    parameter_specs: tuple[ParamSpec, ...] = field(default=(), hash=False)
    # The parameters that decide whether the home pose solves (its geometry, the
    # near-singularity thresholds), geometry first: a model whose home solves
    # near_singular, unreachable or invalid_input is refused
    # (config/whole_machine.py), the error naming those of them a file or a
    # parameter set gave.
    home_parameters: tuple[str, ...] = ()
    parasitic: Mapping[str, Callable[[Any], float]] = field(default_factory=dict, hash=False)
    # The demo planner (ros/planner.py, the demo): the built-in motions it plays in
    # turn (names of ``motions``: the demo, ``--example all``) and the one it plays
    # when not told (``--example``).
    planner_motions: tuple[str, ...] = ()
    planner_example: str = ''

    @property
    def dof(self) -> int:
        """Number of pose coordinates (and of actuated legs)."""
        return len(self.coordinates)

    @property
    def angles(self) -> tuple[int, ...]:
        """Positions in q of the angles (the coordinates in ``rad``): unwrapped across
        +-pi by the rate estimator (core/estimator.py).
        """
        return tuple(i for i, unit in enumerate(self.units) if unit == 'rad')
