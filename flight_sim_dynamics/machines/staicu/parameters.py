"""The 3-DOF machine's parameters (docs/design/mechanism.md): the declaration
of each (type, default, unit, physical bounds, meaning: the paper's application
data, Section 3; geometry of eq. 7-8, mass properties of eq. 18-19, gravity),
and the model built from values checked against them (:func:`from_values`,
:func:`from_params`: the checks of the whole, the loops closing at the central
configuration). Bodies and geometry keys: :data:`.model.BODY_NAMES`,
:data:`.model.GEOMETRY_KEYS`. The builder checks each value against its
declaration (the one check, core/parameter_spec.py, the loaders' too) and the
whole, raising :class:`~flight_sim_dynamics.core.machine.ModelValueError`
naming the key.
"""
from __future__ import annotations

from typing import Any, Mapping

import numpy as np

from ...core.effects import Effects
from ...core.inertia import inertia_tensor
from ...core.machine import ModelValueError
from ...core.parameter_spec import (MAX_COM, MAX_INERTIA, MAX_LENGTH, MAX_MASS, ParamSpec,
                                    checked_values)
from .kinematics import GeometryError, central_configuration
from .model import BODY_NAMES, GEOMETRY_KEYS, Body, Friction, Geometry, Limits, Model

MAX_PATH = 4096             # characters of a scene file's path (PATH_MAX on Linux)


# Model parameters: defaults of mechanism.md and the paper's application data.
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


#: Default mass (kg) and length key of each body: a slender rod along its
#: x axis, centre of mass half-way (pistons point back: -x). The platform is a
#: plate (``_platform_inertia``). Keyed by name, checked against BODY_NAMES.
_BODY_DATA = {
    'cylinder_a': (1.0, 'l1', 1.0), 'piston_a': (1.2, 'l2', -1.0), 'rod': (1.5, 'h', 1.0),
    'platform': (5.0, 'h', 1.0),
    'cylinder_b': (1.0, 'l3', 1.0), 'piston_b': (1.2, 'l4', -1.0),
    'cylinder_c': (1.0, 'l3', 1.0), 'piston_c': (1.2, 'l4', -1.0),
    'crank_d': (1.5, 'l5', 1.0), 'crank_e': (1.4, 'l6', 1.0),
}
if set(_BODY_DATA) != set(BODY_NAMES):      # one list of bodies: the model's
    raise ImportError(f'schema bodies {sorted(_BODY_DATA)} != staicu.model.BODY_NAMES')


def _platform_inertia(mass: float) -> list[float]:
    b, h = _GEOMETRY_DEFAULTS['b'], _GEOMETRY_DEFAULTS['h']
    return [mass * b * b / 12, 0.0, 0.0,
            0.0, mass * (b * b + h * h) / 12, 0.0,
            0.0, 0.0, mass * h * h / 12]


def _model_specs() -> list[ParamSpec]:
    specs = [ParamSpec('gravity', 'double', 9.81,
                       'gravitational acceleration, acting along -y0 (down)', 'm/s^2',
                       minimum=0.0, maximum=100.0)]
    for key in GEOMETRY_KEYS:
        specs.append(ParamSpec(f'geometry.{key}', 'double', _GEOMETRY_DEFAULTS[key],
                               _GEOMETRY_MEANING[key], 'm', minimum=0.0,
                               exclusive_minimum=True, maximum=MAX_LENGTH))
    for name in BODY_NAMES:
        mass, length_key, sign = _BODY_DATA[name]
        length = _GEOMETRY_DEFAULTS[length_key]
        com = [sign * length / 2, 0.0, 0.0]
        inertia = _platform_inertia(mass) if name == 'platform' else _slender(mass, length)
        specs += [
            ParamSpec(f'bodies.{name}.mass', 'double', mass, f'mass of {name}', 'kg',
                      minimum=0.0, exclusive_minimum=True, maximum=MAX_MASS),
            ParamSpec(f'bodies.{name}.com', 'double_array', com,
                      f'centre of mass of {name} in its body frame (x, y, z)', 'm', length=3,
                      minimum=-MAX_COM, maximum=MAX_COM),
            ParamSpec(f'bodies.{name}.inertia', 'double_array', inertia,
                      f'inertia tensor of {name} about its centre of mass, body frame, '
                      'row-major 3x3', 'kg m^2', length=9,
                      minimum=-MAX_INERTIA, maximum=MAX_INERTIA),
        ]
    specs.append(ParamSpec(
        'scene', 'string', 'full',
        'effects to simulate: a scene name from config/scenes (full, quasi_static, '
        'platform_only, payload) or the path of a scene YAML file', required=False,
        max_length=MAX_PATH))
    # used when a scene enables the effect; default payload: a 60 kg cab, an 80 kg occupant
    specs += [
        ParamSpec('payload.mass', 'double', 140.0,
                  'mass of the payload (cab and occupants) on the platform', 'kg',
                  minimum=0.0, exclusive_minimum=True, maximum=MAX_MASS, required=False),
        ParamSpec('payload.com', 'double_array', [0.7, 0.45, 0.0],
                  'payload centre of mass in the platform frame (origin A3; x along the rod '
                  'A3->G, y platform normal up, z lateral right)', 'm', length=3,
                  minimum=-MAX_COM, maximum=MAX_COM, required=False),
        ParamSpec('payload.inertia', 'double_array',
                  [16.0, 0.0, 0.0, 0.0, 20.0, 0.0, 0.0, 0.0, 18.0],
                  'payload inertia tensor about its centre of mass, platform axes, '
                  'row-major 3x3', 'kg m^2', length=9, minimum=-MAX_INERTIA,
                  maximum=MAX_INERTIA, required=False),
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
    # used when a scene enables the 'friction' effect
    specs += [
        ParamSpec('friction.viscous', 'double_array', [20.0, 20.0, 20.0],
                  'viscous friction coefficient of actuators A, B, C', 'N s/m', length=3,
                  minimum=0.0, maximum=1.0e6, required=False),
        ParamSpec('friction.coulomb', 'double_array', [2.0, 2.0, 2.0],
                  'Coulomb (dry) friction force of actuators A, B, C', 'N', length=3,
                  minimum=0.0, maximum=1.0e6, required=False),
        ParamSpec('friction.smoothing_velocity', 'double', 1.0e-3,
                  'rate below which Coulomb friction is smoothed: F_c tanh(rate / v_s)', 'm/s',
                  minimum=0.0, exclusive_minimum=True, maximum=10.0, required=False),
    ]
    return specs


#: Every parameter of a 3-DOF file but the node's own (config/schema.py's NODE_PARAMETERS).
PARAMETER_SPECS: tuple[ParamSpec, ...] = tuple(_model_specs())
#: Their names (dotted).
PARAMETER_NAMES: frozenset[str] = frozenset(spec.name for spec in PARAMETER_SPECS)
#: The packaged file of the 3-DOF machine (config/flight_sim_dynamics.yaml).
PARAMETER_FILES = ('flight_sim_dynamics',)

if set(_GEOMETRY_DEFAULTS) != set(GEOMETRY_KEYS):   # one list of lengths: the model's
    raise ImportError(f'staicu geometry {sorted(_GEOMETRY_DEFAULTS)} != model.GEOMETRY_KEYS')


def check_whole(values: Mapping[str, Any]) -> None:
    """The checks of a complete set of ``values`` (flat dotted names, each
    within its declaration) beyond single values: every inertia tensor a body's
    (:func:`~flight_sim_dynamics.core.inertia.inertia_tensor`), stroke_min <
    stroke_max. ModelValueError naming the key.
    """
    for name in BODY_NAMES:
        inertia_tensor(f'bodies.{name}.inertia', values[f'bodies.{name}.inertia'])
    inertia_tensor('payload.inertia', values['payload.inertia'])
    if not values['limits.stroke_min'] < values['limits.stroke_max']:
        raise ModelValueError('limits.stroke_min',
                              f"must be < limits.stroke_max = {values['limits.stroke_max']:g} m")


def from_values(values: Mapping[str, Any], effects: Effects | None = None,
                scene: str = 'full') -> Model:
    """The :class:`.model.Model` of complete ``values`` (flat dotted names, each
    within its declaration; kept as the model's ``values``) simulating
    ``effects`` (None: all) of the scene named ``scene``. ModelValueError for a
    whole that is no machine (:func:`check_whole`) and for a geometry whose loops
    cannot close at the central configuration (eq. 7-8), naming the key.
    """
    check_whole(values)
    geometry = Geometry(**{k: values[f'geometry.{k}'] for k in GEOMETRY_KEYS})
    bodies = {
        name: Body(mass=values[f'bodies.{name}.mass'],
                   com=np.array(values[f'bodies.{name}.com'], dtype=float),
                   inertia=inertia_tensor(f'bodies.{name}.inertia',
                                          values[f'bodies.{name}.inertia']))
        for name in BODY_NAMES}
    try:
        central = central_configuration(geometry)
    except GeometryError as exc:
        raise ModelValueError(f'geometry.{exc.key}', 'loops cannot close at the central '
                                                     f'configuration: {exc}') from None
    for arr in (*(b.com for b in bodies.values()), *(b.inertia for b in bodies.values())):
        arr.setflags(write=False)
    payload = Body(mass=values['payload.mass'],
                   com=np.array(values['payload.com'], dtype=float),
                   inertia=inertia_tensor('payload.inertia', values['payload.inertia']))
    friction = Friction(viscous=tuple(values['friction.viscous']),
                        coulomb=tuple(values['friction.coulomb']),
                        smoothing_velocity=values['friction.smoothing_velocity'])
    limits = Limits(**{name: values[f'limits.{name}'] for name in Limits.__dataclass_fields__})
    return Model(geometry=geometry, bodies=bodies, gravity=values['gravity'],
                 central=central, values=values, effects=Effects() if effects is None else effects,
                 scene=scene, payload=payload, friction=friction, limits=limits)


def _flat(tree: Mapping[str, Any], prefix: str = '') -> dict[str, Any]:
    out: dict[str, Any] = {}
    for key, value in tree.items():
        if isinstance(value, Mapping):
            out.update(_flat(value, f'{prefix}{key}.'))
        else:
            out[f'{prefix}{key}'] = value
    return out


def from_params(params: Mapping[str, Any], effects: Effects | None = None) -> Model:
    """The model of a file's nested parameters (``geometry: {d1: ...}``; the
    shared loader's call, :attr:`~flight_sim_dynamics.core.machine.Machine.from_params`):
    each given value checked against its declaration
    (:func:`~flight_sim_dynamics.core.parameter_spec.checked_values`), the
    declared defaults of those not given but not required, a ModelValueError
    for a required one missing or a value refused, then
    :func:`from_values` (the model's ``values``: every one given, the machine's
    completed).
    """
    given = _flat(params)
    # each value within its declaration, canonical; the others (the node's) as given
    values = checked_values(PARAMETER_SPECS, given)
    for spec in PARAMETER_SPECS:
        if spec.name in given:
            continue
        if spec.required:
            raise ModelValueError(spec.name, 'missing (every model parameter must be given)')
        values[spec.name] = list(spec.default) if isinstance(spec.default, list) \
            else spec.default
    return from_values(values, effects, str(values.get('scene', 'full')))
