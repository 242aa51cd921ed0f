"""Parameters: the schema of every parameter, YAML loading and validation.

One YAML file in ROS 2 parameter format (``flight_sim_dynamics:
ros__parameters: ...``) feeds both the solver (:func:`load_model`) and the
node (``--ros-args --params-file``). Nested YAML maps become dotted names
(``geometry.d1``, ``bodies.rod.mass``), exactly as ROS 2 flattens them.

Validation is strict and never guesses: a missing, unknown or mistyped key,
a non-positive length or mass, an impossible inertia tensor or a geometry
whose loops cannot close at the central configuration raises
:class:`ParameterError` naming the key and the value. The only conversion
made is an integer given for a floating-point parameter (``mass: 2``), which
is exact and is accepted as the same number.
"""
from __future__ import annotations

import math
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Iterable, Mapping

import numpy as np
import yaml

from ..core.kinematics import GeometryError, central_configuration
from .errors import ParameterError
from .files import (DEFAULT_PARAMS_FILE, NODE_NAME, PACKAGE_NAME, default_params_path, flatten,
                    read_params_file)
from .scenes import Scene, SceneError, load_scene
from ..core.model import BODY_NAMES, GEOMETRY_KEYS, Body, Friction, Geometry, Limits, Model




@dataclass(frozen=True)
class ParamSpec:
    """One declared parameter: its dotted name, type, default and meaning.

    ``kind`` is one of ``double``, ``double_array``, ``integer``, ``string``,
    ``bool``. ``minimum``/``maximum`` bound a number (inclusive unless
    ``exclusive_minimum``); ``length`` fixes the size of an array.
    """

    name: str
    kind: str
    default: Any
    description: str
    unit: str = ''
    minimum: float | None = None
    maximum: float | None = None
    exclusive_minimum: bool = False
    length: int | None = None
    choices: tuple[str, ...] | None = None
    required: bool = True     # a complete model file must give it (model parameters only)

    @property
    def full_description(self) -> str:
        return f'{self.description} [{self.unit}]' if self.unit else self.description


# ----------------------------------------------------------------------------
# Model parameters (geometry, masses, inertias, gravity): defaults of
# mechanism.md and the paper's application data.
# ----------------------------------------------------------------------------
_GEOMETRY_DEFAULTS = dict(d1=0.4, d2=0.95, d3=0.65, d4=0.25, d5=1.35,
                          l1=0.65, l2=0.85, l3=0.75, l4=1.0, l5=1.3, l6=1.2,
                          b=1.2, h=1.4, h_G=1.1, s_A=0.29, s_B=0.33, s_C=0.33)
_GEOMETRY_MEANING = dict(
    d1='A3D2, rod joint to crank D joint', d2='A1E1, base joint A to crank E pivot',
    d3='E1D1, crank E pivot to crank D pivot', d4='D1F, crank D pivot to the B/C base line',
    d5='B1F = C1F, lateral half-spacing of the B and C base joints',
    l1='length of cylinder A', l2='length of piston A (A2A3)',
    l3='length of cylinders B and C', l4='length of pistons B and C (B3B4)',
    l5='length of crank D (D1D2)', l6='length of crank E (E1E2)',
    b='platform width B4C4', h='rod and platform length A3G',
    h_G='elevation of G at the central configuration',
    s_A='A1A2 at zero stroke', s_B='B1B3 at zero stroke', s_C='C1C3 at zero stroke')


def _slender(mass: float, length: float) -> list[float]:
    i = mass * length ** 2 / 12.0
    return [0.0, 0.0, 0.0, 0.0, i, 0.0, 0.0, 0.0, i]


def _body_defaults() -> dict[str, tuple[float, list[float], list[float]]]:
    g = _GEOMETRY_DEFAULTS
    m_plat, b, h = 5.0, g['b'], g['h']
    return {
        'cylinder_a': (1.0, [g['l1'] / 2, 0.0, 0.0], _slender(1.0, g['l1'])),
        'piston_a': (1.2, [-g['l2'] / 2, 0.0, 0.0], _slender(1.2, g['l2'])),
        'rod': (1.5, [h / 2, 0.0, 0.0], _slender(1.5, h)),
        'platform': (m_plat, [h / 2, 0.0, 0.0],
                     [m_plat * b * b / 12, 0.0, 0.0,
                      0.0, m_plat * (b * b + h * h) / 12, 0.0,
                      0.0, 0.0, m_plat * h * h / 12]),
        'cylinder_b': (1.0, [g['l3'] / 2, 0.0, 0.0], _slender(1.0, g['l3'])),
        'piston_b': (1.2, [-g['l4'] / 2, 0.0, 0.0], _slender(1.2, g['l4'])),
        'cylinder_c': (1.0, [g['l3'] / 2, 0.0, 0.0], _slender(1.0, g['l3'])),
        'piston_c': (1.2, [-g['l4'] / 2, 0.0, 0.0], _slender(1.2, g['l4'])),
        'crank_d': (1.5, [g['l5'] / 2, 0.0, 0.0], _slender(1.5, g['l5'])),
        'crank_e': (1.4, [g['l6'] / 2, 0.0, 0.0], _slender(1.4, g['l6'])),
    }


def _model_specs() -> list[ParamSpec]:
    specs = [ParamSpec('gravity', 'double', 9.81,
                       'gravitational acceleration, acting along -y0 (down)', 'm/s^2',
                       minimum=0.0, maximum=100.0)]
    for key in GEOMETRY_KEYS:
        specs.append(ParamSpec(f'geometry.{key}', 'double', _GEOMETRY_DEFAULTS[key],
                               _GEOMETRY_MEANING[key], 'm', minimum=0.0,
                               exclusive_minimum=True, maximum=100.0))
    for name, (mass, com, inertia) in _body_defaults().items():
        specs += [
            ParamSpec(f'bodies.{name}.mass', 'double', mass, f'mass of {name}', 'kg',
                      minimum=0.0, exclusive_minimum=True, maximum=1.0e6),
            ParamSpec(f'bodies.{name}.com', 'double_array', com,
                      f'centre of mass of {name} in its body frame (x, y, z)', 'm', length=3),
            ParamSpec(f'bodies.{name}.inertia', 'double_array', inertia,
                      f'inertia tensor of {name} about its centre of mass, body frame, '
                      'row-major 3x3', 'kg m^2', length=9),
        ]
    specs.append(ParamSpec(
        'scene', 'string', 'full',
        'effects to simulate: a scene name from config/scenes (full, quasi_static, '
        'platform_only, payload) or the path of a scene YAML file', required=False))
    # payload (cab and occupants): used when a scene enables the 'payload' effect.
    # Defaults: a 60 kg cab plus an 80 kg occupant centred on the platform.
    specs += [
        ParamSpec('payload.mass', 'double', 140.0,
                  'mass of the payload (cab and occupants) on the platform', 'kg',
                  minimum=0.0, exclusive_minimum=True, maximum=1.0e6, required=False),
        ParamSpec('payload.com', 'double_array', [0.7, 0.45, 0.0],
                  'payload centre of mass in the platform frame (origin A3; x along the rod '
                  'A3->G, y platform normal up, z lateral right)', 'm', length=3,
                  required=False),
        ParamSpec('payload.inertia', 'double_array',
                  [16.0, 0.0, 0.0, 0.0, 20.0, 0.0, 0.0, 0.0, 18.0],
                  'payload inertia tensor about its centre of mass, platform axes, '
                  'row-major 3x3', 'kg m^2', length=9, required=False),
    ]
    # actuator limits and near-singularity thresholds: the status of every solve
    specs += [
        ParamSpec('limits.stroke_min', 'double', -0.3,
                  'lowest allowed actuator stroke (leg length minus its zero-stroke length)',
                  'm', minimum=-10.0, maximum=10.0, required=False),
        ParamSpec('limits.stroke_max', 'double', 0.6,
                  'highest allowed actuator stroke; must be > limits.stroke_min', 'm',
                  minimum=-10.0, maximum=10.0, required=False),
        ParamSpec('limits.max_speed', 'double', 1.0, 'largest allowed actuator speed |dL/dt|',
                  'm/s', minimum=0.0, exclusive_minimum=True, maximum=1.0e3, required=False),
        ParamSpec('limits.max_force', 'double', 2000.0, 'largest allowed actuator force |f|',
                  'N', minimum=0.0, exclusive_minimum=True, maximum=1.0e9, required=False),
        ParamSpec('limits.max_kinematic_condition', 'double', 100.0,
                  'status near_singular beyond this condition number of the connectivity '
                  'matrix Q (largest 2-norm condition of the pivot blocks of its block '
                  'factorisation)', '1', minimum=1.0, maximum=1.0e16, required=False),
        ParamSpec('limits.max_jacobian_condition', 'double', 100.0,
                  'status near_singular beyond this condition number of the actuator '
                  'Jacobian dL/dq (Frobenius, roll column scaled by b/2)', '1',
                  minimum=1.0, maximum=1.0e16, required=False),
    ]
    # actuator friction: used when a scene enables the 'friction' effect.
    specs += [
        ParamSpec('friction.viscous', 'double_array', [20.0, 20.0, 20.0],
                  'viscous friction coefficient of actuators A, B, C', 'N s/m', length=3,
                  required=False),
        ParamSpec('friction.coulomb', 'double_array', [2.0, 2.0, 2.0],
                  'Coulomb (dry) friction force of actuators A, B, C', 'N', length=3,
                  required=False),
        ParamSpec('friction.smoothing_velocity', 'double', 1.0e-3,
                  'rate below which Coulomb friction is smoothed: F_c tanh(rate / v_s)', 'm/s',
                  minimum=0.0, exclusive_minimum=True, maximum=10.0, required=False),
    ]
    return specs


MODEL_PARAMETERS: tuple[ParamSpec, ...] = tuple(_model_specs())

# ----------------------------------------------------------------------------
# Node parameters (limits, tolerances, QoS, ...): declared by the node, also
# accepted in the YAML read by load_model so that one file serves both.
# ----------------------------------------------------------------------------
NODE_PARAMETERS: tuple[ParamSpec, ...] = (
    # Near-limit warnings (the limits themselves are model parameters: limits.*).
    ParamSpec('limits.warn_fraction', 'double', 0.9,
              'status WARN when a stroke, speed or force uses at least this fraction of its '
              'limit (stroke: of the half-range around its middle)', '1',
              minimum=0.0, maximum=1.0),
    # Input checks.
    ParamSpec('input.max_linear_acceleration', 'double', 50.0,
              'setpoints whose surge or heave acceleration (given or estimated) exceeds this '
              'are rejected as absurd', 'm/s^2',
              minimum=0.0, exclusive_minimum=True, maximum=1.0e6),
    ParamSpec('input.max_angular_acceleration', 'double', 100.0,
              'setpoints whose roll acceleration (given or estimated) exceeds this are '
              'rejected as absurd', 'rad/s^2',
              minimum=0.0, exclusive_minimum=True, maximum=1.0e6),
    ParamSpec('input.quaternion_tolerance', 'double', 1.0e-3,
              'largest accepted | |q| - 1 | of an orientation quaternion (it is then '
              'normalised); beyond it the setpoint is rejected', '1',
              minimum=0.0, maximum=0.5),
    ParamSpec('input.position_tolerance', 'double', 1.0e-3,
              'sway (position.y, and linear.y of twist and acceleration per s, s^2) beyond '
              'this is reported as motion the mechanism cannot follow, then ignored', 'm',
              minimum=0.0, maximum=10.0),
    ParamSpec('input.angle_tolerance', 'double', 1.0e-3,
              'yaw, and a pitch other than zero or the parasitic pitch, beyond this is '
              'reported as motion the mechanism cannot follow, then ignored', 'rad',
              minimum=0.0, maximum=3.2),
    # Exact-stamp synchroniser.
    ParamSpec('sync.wait', 'double', 0.05,
              'longest wait for the twist and acceleration carrying a pose\'s stamp before '
              'the setpoint is solved without them (they are then estimated)', 's',
              minimum=0.0, maximum=10.0),
    ParamSpec('sync.max_pending', 'integer', 64,
              'most setpoint stamps waiting for their other messages at once', '1',
              minimum=1, maximum=100000),
    # Estimation of missing rates / accelerations.
    ParamSpec('estimator.method', 'string', 'backward2',
              'finite differences for missing rates and accelerations: backward (2-point, '
              'first order) or backward2 (3-point BDF2, second order)', '',
              choices=('backward', 'backward2')),
    ParamSpec('estimator.max_gap', 'double', 0.5,
              'a gap between setpoint stamps longer than this restarts the estimator '
              '(motion assumed to start from rest)', 's',
              minimum=0.0, exclusive_minimum=True, maximum=3600.0),
    # (QoS: rclpy's read-only qos_overrides.<topic>.* parameters, declared by
    # the node's endpoints; docs/node.md.)
    # Diagnostics and logging.
    ParamSpec('diagnostics.period', 'double', 1.0,
              'period of the /diagnostics message', 's',
              minimum=0.01, maximum=3600.0),
    ParamSpec('diagnostics.log_throttle', 'double', 2.0,
              'at most one log line per rejection reason per this period', 's',
              minimum=0.0, maximum=3600.0),
    # Outputs.
    ParamSpec('output.frame_id', 'string', 'simulator_base',
              'header.frame_id of actuator_states: the REP-103 simulator base frame '
              '(origin at G\'s central position); leg lengths are frame-free scalars', ''),
    ParamSpec('output.joint_states_frame_id', 'string', 'simulator_base',
              'header.frame_id of joint_states (the 12 joint variables)', ''),
)

ALL_PARAMETERS: tuple[ParamSpec, ...] = MODEL_PARAMETERS + NODE_PARAMETERS
SPECS: Mapping[str, ParamSpec] = {spec.name: spec for spec in ALL_PARAMETERS}


def defaults() -> dict[str, Any]:
    """The packaged default value of every parameter, by dotted name."""
    return {spec.name: (list(spec.default) if isinstance(spec.default, list) else spec.default)
            for spec in ALL_PARAMETERS}


# ----------------------------------------------------------------------------
# YAML
# ----------------------------------------------------------------------------
# ----------------------------------------------------------------------------
# Validation
# ----------------------------------------------------------------------------
def check_value(spec: ParamSpec, value: Any) -> Any:
    """Type- and range-check one value against its spec; returns it in its
    canonical Python type (float, list of floats, int, str, bool)."""
    key = spec.name

    def number(v: Any, where: str = '') -> float:
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise ParameterError(key, value, f'expected a number{where}, got {type(v).__name__}')
        v = float(v)
        if not math.isfinite(v):
            raise ParameterError(key, value, f'must be finite{where}')
        return v

    if spec.kind == 'double':
        v = number(value)
        if spec.minimum is not None:
            if spec.exclusive_minimum and v <= spec.minimum:
                raise ParameterError(key, value, f'must be > {spec.minimum:g} {spec.unit}'.rstrip())
            if not spec.exclusive_minimum and v < spec.minimum:
                raise ParameterError(key, value, f'must be >= {spec.minimum:g} {spec.unit}'.rstrip())
        if spec.maximum is not None and v > spec.maximum:
            raise ParameterError(key, value, f'must be <= {spec.maximum:g} {spec.unit}'.rstrip())
        return v
    if spec.kind == 'double_array':
        if isinstance(value, (str, bytes)) or not isinstance(value, (list, tuple, np.ndarray)):
            raise ParameterError(key, value, f'expected a list of {spec.length} numbers')
        items = [number(v, f' (element {i})') for i, v in enumerate(value)]
        if spec.length is not None and len(items) != spec.length:
            raise ParameterError(key, value,
                                 f'expected {spec.length} numbers, got {len(items)}')
        return items
    if spec.kind == 'integer':
        if isinstance(value, bool) or not isinstance(value, int):
            raise ParameterError(key, value, f'expected an integer, got {type(value).__name__}')
        if spec.minimum is not None and value < spec.minimum:
            raise ParameterError(key, value, f'must be >= {spec.minimum:g}')
        if spec.maximum is not None and value > spec.maximum:
            raise ParameterError(key, value, f'must be <= {spec.maximum:g}')
        return value
    if spec.kind == 'string':
        if not isinstance(value, str):
            raise ParameterError(key, value, f'expected a string, got {type(value).__name__}')
        if spec.choices is not None and value not in spec.choices:
            raise ParameterError(key, value, f"must be one of {', '.join(spec.choices)}")
        return value
    if spec.kind == 'bool':
        if not isinstance(value, bool):
            raise ParameterError(key, value, f'expected true or false, got {type(value).__name__}')
        return value
    raise AssertionError(f'unknown parameter kind {spec.kind}')  # pragma: no cover


def check_inertia(key: str, value: Iterable[float]) -> np.ndarray:
    """A 3x3 inertia tensor must be symmetric and physically possible: principal
    moments >= 0 and each no larger than the sum of the other two."""
    tensor = np.asarray(value, dtype=float).reshape(3, 3)
    scale = max(float(np.max(np.abs(tensor))), 1e-300)
    if np.max(np.abs(tensor - tensor.T)) > 1e-9 * scale:
        raise ParameterError(key, list(value), 'inertia tensor is not symmetric')
    moments = np.linalg.eigvalsh(0.5 * (tensor + tensor.T))
    tol = 1e-9 * scale
    if moments[0] < -tol:
        raise ParameterError(key, list(value),
                             f'inertia tensor is not positive semi-definite '
                             f'(principal moment {moments[0]:.6g})')
    if moments[2] > moments[0] + moments[1] + tol:
        raise ParameterError(key, list(value),
                             'principal moments violate the triangle inequality '
                             f'({moments[2]:.6g} > {moments[0]:.6g} + {moments[1]:.6g})')
    return 0.5 * (tensor + tensor.T)


def validate(values: Mapping[str, Any], *, require_all: bool = True) -> dict[str, Any]:
    """Check a flat dict of parameters against the schema.

    Unknown keys are errors. With ``require_all`` every required model
    parameter (gravity, geometry, bodies) must be present (as when loading a
    complete file); otherwise missing ones take their packaged defaults. Effect
    parameters (payload, friction) and node parameters default when absent.
    Returns the complete, canonical flat dict.
    """
    for key in values:
        if key not in SPECS:
            raise ParameterError(key, values[key], 'unknown parameter')
    result = defaults()
    for spec in ALL_PARAMETERS:
        if spec.name in values:
            result[spec.name] = check_value(spec, values[spec.name])
        elif require_all and spec.required and spec in MODEL_PARAMETERS:
            raise ParameterError(spec.name, None, 'missing (every model parameter must be given)')
    for name in BODY_NAMES:
        check_inertia(f'bodies.{name}.inertia', result[f'bodies.{name}.inertia'])
    check_inertia('payload.inertia', result['payload.inertia'])
    for key in ('friction.viscous', 'friction.coulomb'):
        if min(result[key]) < 0.0:
            raise ParameterError(key, result[key], 'friction coefficients must be >= 0')
    if not result['limits.stroke_min'] < result['limits.stroke_max']:
        raise ParameterError('limits.stroke_min', result['limits.stroke_min'],
                             f"must be < limits.stroke_max = {result['limits.stroke_max']:g} m")
    return result


def model_from_values(values: Mapping[str, Any], *, require_all: bool = True,
                      scene: Scene | str | None = None) -> Model:
    """Validate ``values`` (flat dotted names) and build the :class:`Model`.

    ``scene`` (a :class:`~.effects.Scene`, a scene name or path; None = the
    ``scene`` parameter in ``values``, else ``full``) selects the effects; its
    parameter overrides apply on top of ``values``.
    Raises :class:`ParameterError` if anything is invalid, including a geometry
    whose loops cannot close at the central configuration (crank D, crank E
    meeting the rod between A3 and G), and :class:`~.effects.SceneError` for a
    bad scene."""
    if scene is None:
        scene = values.get('scene', SPECS['scene'].default)
        if not isinstance(scene, str):
            raise ParameterError('scene', scene, 'expected a scene name or a file path')
    scene = scene if isinstance(scene, Scene) else load_scene(scene)
    values = dict(values)
    values['scene'] = scene.name if scene.path is None else str(scene.path)
    for key, value in scene.parameters.items():
        if key not in SPECS or SPECS[key] not in MODEL_PARAMETERS:
            raise SceneError(scene.name, f"parameter '{key}' is not a model parameter")
        values[key] = value
    checked = validate(values, require_all=require_all)
    geometry = Geometry(**{k: checked[f'geometry.{k}'] for k in GEOMETRY_KEYS})
    bodies = {
        name: Body(mass=checked[f'bodies.{name}.mass'],
                   com=np.array(checked[f'bodies.{name}.com'], dtype=float),
                   inertia=check_inertia(f'bodies.{name}.inertia',
                                         checked[f'bodies.{name}.inertia']))
        for name in BODY_NAMES}
    try:
        central = central_configuration(geometry)
    except GeometryError as exc:
        raise ParameterError(f'geometry.{exc.key}', checked[f'geometry.{exc.key}'],
                             f'loops cannot close at the central configuration: {exc}') from None
    for arr in (*(b.com for b in bodies.values()), *(b.inertia for b in bodies.values())):
        arr.setflags(write=False)
    payload = Body(mass=checked['payload.mass'],
                   com=np.array(checked['payload.com'], dtype=float),
                   inertia=check_inertia('payload.inertia', checked['payload.inertia']))
    friction = Friction(viscous=tuple(checked['friction.viscous']),
                        coulomb=tuple(checked['friction.coulomb']),
                        smoothing_velocity=checked['friction.smoothing_velocity'])
    limits = Limits(**{name: checked[f'limits.{name}'] for name in Limits.__dataclass_fields__})
    return Model(geometry=geometry, bodies=bodies, gravity=checked['gravity'],
                 central=central, values=checked, effects=scene.effects, scene=scene.name,
                 payload=payload, friction=friction, limits=limits)


def load_model(path: str | os.PathLike[str] | None = None,
               scene: str | os.PathLike[str] | None = None) -> Model:
    """Load and validate a parameter file (None: the packaged defaults) and a
    scene (a name from config/scenes or a path; None: the file's ``scene``
    parameter if it has one, else ``full``, the paper's model).

    The file must give every required model parameter (gravity, geometry,
    bodies); effect parameters (payload, friction) and node parameters may be
    present and default when absent."""
    values = read_params_file(default_params_path() if path is None else path)
    return model_from_values(values, require_all=True, scene=scene)
