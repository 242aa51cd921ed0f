"""The model of a 6-UPS hexapod, constant: joints, bodies, limits, effects
(docs/design/stewart.md, "Frames and coordinates" to "The parameter file").

Any 6-UPS hexapod: the joints are explicit coordinates. :func:`from_dict`
builds a :class:`StewartModel` from the ``ros__parameters`` of a parameter
file and rejects a bad number with a ValueError
that names its field (reading the file is the configuration's job).
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass, field, replace
from typing import Mapping

import numpy as np

from ...core.effects import Effects
from ...core.machine import ModelValueError

#: Legs, in the order of the parameter file's joints.
LEG_NAMES = tuple(f'leg_{i}' for i in range(1, 7))

#: |cos theta_2| below which a U-joint is singular (S5, "Singular cases"): unreachable.
U_JOINT_TOLERANCE = 1e-6
#: Leg length at or below which u_i is undefined (S4, "Singular cases"): unreachable, m.
MIN_LENGTH = 1e-9
#: Why a leg makes a solve unreachable (its status info = leg + 6 x the reason's index).
UNREACHABLE_REASONS = ('degenerate_length', 'not_finite', 'u_joint')
#: Condition of J from which J^-T is not formed (S21): singular to working
#: precision (status near_singular, forces 0). Well below 1 / eps: the condition
#: an exactly singular J shows is round-off, 1e13 to 1e17 depending on the method.
MAX_SOLVED_CONDITION = 1e12


def _freeze(obj: object, *names: str) -> None:
    """Replace the array fields ``names`` of a frozen dataclass by read-only copies."""
    for name in names:
        a = np.array(getattr(obj, name), dtype=float)
        a.setflags(write=False)
        object.__setattr__(obj, name, a)


@dataclass(frozen=True)
class RigidBody:
    """A body fixed to the platform (platform frame): mass, centre of mass,
    inertia about the centre of mass (S16).
    """

    mass: float          # kg
    com: np.ndarray      # (3,) m, platform frame
    inertia: np.ndarray  # (3, 3) kg m^2, platform frame

    def __post_init__(self) -> None:
        _freeze(self, 'com', 'inertia')


@dataclass(frozen=True)
class LegBody:
    """A cylinder (from B_i) or rod (from P_i), axisymmetric about the leg (S14-S15)."""

    mass: float            # kg
    com_distance: float    # m, from its end joint along the leg
    inertia_across: float  # kg m^2, about an axis across the leg through the com
    inertia_along: float   # kg m^2, about the leg axis


@dataclass(frozen=True)
class Friction:
    """Actuator friction (S23), used when the scene enables it:
    f = viscous x rate + coulomb x tanh(rate / smoothing_velocity), per leg.
    """

    viscous: np.ndarray = field(default_factory=lambda: np.zeros(6))   # N s/m
    coulomb: np.ndarray = field(default_factory=lambda: np.zeros(6))   # N
    smoothing_velocity: float = 1e-3                                   # m/s

    def __post_init__(self) -> None:
        _freeze(self, 'viscous', 'coulomb')


@dataclass(frozen=True)
class Limits:
    """Actuator and joint limits: beyond them a solve's status is ``limit``
    (``near_singular`` beyond the Jacobian's condition). Joint-angle limits
    are off (None) unless given.
    """

    length_min: float                      # m, shortest leg (joint centre to joint centre)
    length_max: float                      # m, longest leg
    max_speed: float                       # m/s, largest |dL/dt|
    max_force: float                       # N, largest |f|
    max_jacobian_condition: float = 100.0  # 2-norm condition of J (m, rad) (S21)
    u_joint_max_angle: float | None = None          # rad, largest |theta_1|, |theta_2| (S5)
    spherical_joint_max_angle: float | None = None  # rad, largest angle of u_i from the
    #                                                 platform's z axis
    warn_fraction: float = 0.9             # node parameter: warn from this fraction on


@dataclass(frozen=True)
class StewartModel:
    """Everything constant about one hexapod (arrays: leg i is row i)."""

    name: str
    base_joints: np.ndarray      # (6, 3) B_i, base frame, m
    platform_joints: np.ndarray  # (6, 3) p_i, platform frame, m
    base_axes: np.ndarray        # (6, 3) a_1,i, unit, base frame (U-joint first axes)
    home: np.ndarray             # (3,) platform origin at home, base frame, m
    gravity: float               # m/s^2, along -z
    platform: RigidBody
    cylinder: LegBody
    rod: LegBody
    payload: RigidBody
    friction: Friction
    limits: Limits
    effects: Effects = field(default_factory=Effects)
    scene: str = 'full'
    # derived once (S5): the U-joints' base frames C_i = [e1 e2 e3], (6, 3, 3)
    leg_frames: np.ndarray = field(init=False, repr=False, compare=False)
    home_lengths: np.ndarray = field(init=False, repr=False, compare=False)  # (6,) m

    def __post_init__(self) -> None:
        object.__setattr__(self, 'leg_frames', u_joint_frames(self.base_axes))
        d = self.home + self.platform_joints - self.base_joints
        object.__setattr__(self, 'home_lengths', np.linalg.norm(d, axis=1))
        _freeze(self, 'base_joints', 'platform_joints', 'base_axes', 'home', 'leg_frames',
                'home_lengths')

    def with_effects(self, effects: Effects, scene: str | None = None) -> 'StewartModel':
        """The same hexapod simulating another set of effects."""
        return replace(self, effects=effects, scene=scene if scene is not None else 'custom')

    def with_payload(self, mass: float, com=(0.0, 0.0, 0.0), inertia=None) -> 'StewartModel':
        """The same hexapod with another payload (inertia about its com, platform frame)."""
        body = _rigid('payload', {'mass': mass, 'com': list(com),
                                  'inertia': [0.0] * 9 if inertia is None
                                  else np.asarray(inertia, dtype=float).ravel().tolist()},
                      allow_zero_mass=True)
        return replace(self, payload=body)


def u_joint_frames(axes: np.ndarray) -> np.ndarray:
    """C_i = [e1 e2 e3] of (S5): e1 = a_1,i; e3 the base z made perpendicular to
    a_1,i and normalised (the base x if a_1,i is vertical); e2 = e3 x e1.
    """
    e1 = axes
    vertical = np.abs(e1[:, 2]) >= 0.9
    ref = np.where(vertical[:, None], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0])
    e3 = ref - np.sum(ref * e1, axis=1, keepdims=True) * e1
    e3 /= np.linalg.norm(e3, axis=1, keepdims=True)
    e2 = np.cross(e3, e1)
    return np.stack([e1, e2, e3], axis=-1)


# ---------------------------------------------------------------------------
# From the parameter file's layout (stewart.md, "The parameter file")
# ---------------------------------------------------------------------------

_TOP = {'machine', 'gravity', 'scene', 'geometry', 'bodies', 'payload', 'friction', 'limits'}
_GEOMETRY = {'base_joints', 'platform_joints', 'base_axes', 'home'}
_RIGID = {'mass', 'com', 'inertia'}
_LEG = {'mass', 'com_distance', 'inertia_across', 'inertia_along'}
_FRICTION = {'viscous', 'coulomb', 'smoothing_velocity'}
_LIMITS_REQUIRED = ('length_min', 'length_max', 'max_speed', 'max_force')
_LIMITS_OPTIONAL = ('max_jacobian_condition', 'u_joint_max_angle',
                    'spherical_joint_max_angle', 'warn_fraction')
#: The names a hexapod's parameter file may give, dotted as ROS 2 flattens them.
PARAMETER_NAMES = frozenset(
    {'machine', 'gravity', 'scene'} | {f'geometry.{k}' for k in _GEOMETRY}
    | {f'{body}.{k}' for body in ('bodies.platform', 'payload') for k in _RIGID}
    | {f'bodies.{leg}.{k}' for leg in ('cylinder', 'rod') for k in _LEG}
    | {f'friction.{k}' for k in _FRICTION}
    | {f'limits.{k}' for k in _LIMITS_REQUIRED + _LIMITS_OPTIONAL})


def _error(name: str, message: str) -> ModelValueError:
    """The error of field ``name`` (an element's index dropped from its key)."""
    return ModelValueError(re.sub(r'\[\d+\]$', '', name), message)


def _key(section: str, name: str) -> str:
    """The dotted name of ``name`` in ``section`` ('parameters': the top level)."""
    return name if section == 'parameters' else f'{section}.{name}'


def _section(name: str, value: object, keys: set, required: set | None = None) -> Mapping:
    if not isinstance(value, Mapping):
        raise _error(name, f'{name} must be a mapping, got {value!r:.100}')
    unknown = sorted(map(str, set(value) - keys))
    if unknown:
        raise _error(_key(name, unknown[0]), f'{name}: unknown key(s) {", ".join(unknown)}')
    missing = sorted((keys if required is None else required) - set(value))
    if missing:
        raise _error(_key(name, missing[0]), f'{name}: missing key(s) {", ".join(missing)}')
    return value


def _number(name: str, value: object, low: float = -math.inf, *, strict: bool = False) -> float:
    """A finite real number >= low (> low if strict), or ValueError naming the field."""
    if isinstance(value, bool) or not isinstance(value, (int, float, np.floating, np.integer)):
        raise _error(name, f'{name} must be a number, got {value!r:.100}')
    x = float(value)
    if not math.isfinite(x):
        raise _error(name, f'{name} must be finite, got {x}')
    if x < low or (strict and x == low):
        raise _error(name, f'{name} must be {">" if strict else ">="} {low:g}, got {x:g}')
    return x


def _numbers(name: str, value: object, n: int, low: float = -math.inf) -> np.ndarray:
    if isinstance(value, (str, bytes, Mapping)) or not hasattr(value, '__len__'):
        raise _error(name, f'{name} must be a list of {n} numbers, got {value!r:.100}')
    if len(value) != n:
        raise _error(name, f'{name} must be a list of {n} numbers, got {len(value)}')
    return np.array([_number(f'{name}[{i}]', v, low) for i, v in enumerate(value)])


def _rigid(name: str, d: object, allow_zero_mass: bool = False) -> RigidBody:
    d = _section(name, d, _RIGID)
    mass = _number(f'{name}.mass', d['mass'], 0.0, strict=not allow_zero_mass)
    inertia = _numbers(f'{name}.inertia', d['inertia'], 9).reshape(3, 3)
    scale = max(1.0, float(np.abs(inertia).max()))
    if not np.allclose(inertia, inertia.T, rtol=0.0, atol=1e-12 * scale):
        raise _error(f'{name}.inertia',
                     f'{name}.inertia must be symmetric, got {inertia.ravel().tolist()}')
    eig = np.linalg.eigvalsh(inertia)
    if eig[0] < -1e-12 * scale or eig[2] > eig[0] + eig[1] + 1e-9 * scale:
        raise _error(f'{name}.inertia', f'{name}.inertia is not a body\'s inertia (principal '
                     f'moments {eig.tolist()}: each must be >= 0 and at most the sum of the '
                     'others)')
    if mass == 0.0 and np.any(inertia != 0.0):
        raise _error(f'{name}.inertia', f'{name}.inertia must be zero for a body of no mass')
    return RigidBody(mass, _numbers(f'{name}.com', d['com'], 3), inertia)


def _leg(name: str, d: object) -> LegBody:
    d = _section(name, d, _LEG)
    return LegBody(*(_number(f'{name}.{k}', d[k], 0.0) for k in
                     ('mass', 'com_distance', 'inertia_across', 'inertia_along')))


def _points(name: str, value: object) -> np.ndarray:
    return _numbers(name, value, 18).reshape(6, 3)


def _limits(d: object) -> Limits:
    d = _section('limits', d, set(_LIMITS_REQUIRED + _LIMITS_OPTIONAL), set(_LIMITS_REQUIRED))
    lo = _number('limits.length_min', d['length_min'], 0.0, strict=True)
    hi = _number('limits.length_max', d['length_max'], lo, strict=True)
    out = {'length_min': lo, 'length_max': hi,
           'max_speed': _number('limits.max_speed', d['max_speed'], 0.0, strict=True),
           'max_force': _number('limits.max_force', d['max_force'], 0.0, strict=True)}
    if 'max_jacobian_condition' in d:
        out['max_jacobian_condition'] = _number('limits.max_jacobian_condition',
                                                d['max_jacobian_condition'], 1.0)
    for key in ('u_joint_max_angle', 'spherical_joint_max_angle'):
        if d.get(key) is not None:
            out[key] = _number(f'limits.{key}', d[key], 0.0, strict=True)
            if out[key] > math.pi:
                raise _error(f'limits.{key}',
                             f'limits.{key} must be <= pi rad, got {out[key]:g}')
    if 'warn_fraction' in d:
        out['warn_fraction'] = _number('limits.warn_fraction', d['warn_fraction'], 0.0,
                                       strict=True)
        if out['warn_fraction'] > 1.0:
            raise _error('limits.warn_fraction',
                         f'limits.warn_fraction must be <= 1, got {out["warn_fraction"]:g}')
    return Limits(**out)


def _friction(d: object) -> Friction:
    d = _section('friction', d, _FRICTION)
    return Friction(_numbers('friction.viscous', d['viscous'], 6, 0.0),
                    _numbers('friction.coulomb', d['coulomb'], 6, 0.0),
                    _number('friction.smoothing_velocity', d['smoothing_velocity'], 0.0,
                            strict=True))


def from_dict(params: Mapping, effects: Effects | None = None) -> StewartModel:
    """The model of a parameter file's ``ros__parameters``, nested (the
    configuration picks the node's sections). ``payload`` and ``friction`` may
    be left out (zero).
    ``effects`` are the effects of the scene the file names (the caller
    resolves the name); left out, they are scene full's, :class:`Effects`'
    defaults, and any other scene name is a ValueError.
    """
    params = _section('parameters', params, _TOP, _TOP - {'payload', 'friction', 'scene'})
    name = params['machine']
    if not isinstance(name, str) or not name:
        raise _error('machine', f'machine must be a name, got {name!r:.100}')
    scene = params.get('scene', 'full')
    if not isinstance(scene, str) or not scene:
        raise _error('scene', f'scene must be a name, got {scene!r:.100}')
    if effects is None and scene != 'full':
        raise _error('scene', f"scene '{scene}': pass its effects (scene full's are the "
                     'defaults)')
    geo = _section('geometry', params['geometry'], _GEOMETRY)
    base = _points('geometry.base_joints', geo['base_joints'])
    plat = _points('geometry.platform_joints', geo['platform_joints'])
    axes = _points('geometry.base_axes', geo['base_axes'])
    home = _numbers('geometry.home', geo['home'], 3)
    with np.errstate(over='ignore', invalid='ignore'):    # finite numbers whose norms overflow
        norms = np.linalg.norm(axes, axis=1)
        reach = np.linalg.norm(home + plat - base, axis=1)
    if not np.all(np.isfinite(norms)):
        raise _error('geometry.base_axes', 'geometry.base_axes: too large (the length of an '
                     'axis is beyond the floating-point range)')
    if not np.all(np.isfinite(reach)):
        key = max((('geometry.base_joints', base), ('geometry.platform_joints', plat),
                   ('geometry.home', home)), key=lambda kv: float(np.abs(kv[1]).max()))[0]
        raise _error(key, f'{key}: too large (a leg\'s length at home is beyond the '
                     'floating-point range)')
    if np.any(norms < 1e-9):
        raise _error('geometry.base_axes',
                     f'geometry.base_axes: axis of leg {int(np.argmin(norms)) + 1} is zero')
    bodies = _section('bodies', params['bodies'], {'platform', 'cylinder', 'rod'})
    payload = params.get('payload', {'mass': 0.0, 'com': [0.0] * 3, 'inertia': [0.0] * 9})
    model = StewartModel(
        name=name, base_joints=base, platform_joints=plat, base_axes=axes / norms[:, None],
        home=home, gravity=_number('gravity', params['gravity'], 0.0),
        platform=_rigid('bodies.platform', bodies['platform']),
        cylinder=_leg('bodies.cylinder', bodies['cylinder']),
        rod=_leg('bodies.rod', bodies['rod']),
        payload=_rigid('payload', payload, allow_zero_mass=True),
        friction=_friction(params['friction']) if 'friction' in params else Friction(),
        limits=_limits(params['limits']),
        effects=Effects() if effects is None else effects, scene=scene)
    _check_home(model)
    return model


def _check_home(model: StewartModel) -> None:
    """Home must be a regular pose: legs of positive length, U-joints not singular (S5)."""
    d = model.home + model.platform_joints - model.base_joints
    L = np.linalg.norm(d, axis=1)
    for i in range(6):
        if L[i] <= MIN_LENGTH:
            raise _error('geometry.home', f'geometry.home: leg {i + 1} has zero length at home')
        s2 = float(model.base_axes[i] @ d[i] / L[i])
        if 1.0 - s2 * s2 < U_JOINT_TOLERANCE ** 2:
            raise _error('geometry.base_axes', f'geometry.base_axes: leg {i + 1} lies along '
                         'its U-joint\'s first axis at home (singular joint)')

