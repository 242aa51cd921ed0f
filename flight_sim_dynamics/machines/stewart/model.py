"""The model of a 6-UPS hexapod, constant: joints, bodies, limits, effects
(docs/design/stewart.md, "Frames and coordinates" to "The parameter file").

Any 6-UPS hexapod: the joints are explicit coordinates. :func:`from_dict`
builds a :class:`StewartModel` from the ``ros__parameters`` of a parameter
file, each value checked against its declaration (.parameters), and rejects
a bad one with a ModelValueError that names its field (reading the file is
the configuration's job).
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any, Mapping

import numpy as np

from ...core.effects import Effects
from ...core.parameter_spec import ModelValueError, check_value
from .parameters import MAX_JACOBIAN_CONDITION, PARAMETER_NAMES, PARAMETER_SPECS, SPECS

__all__ = ['LEG_NAMES', 'PARAMETER_NAMES', 'Friction', 'LegBody', 'Limits', 'RigidBody',
           'StewartModel', 'from_dict', 'u_joint_frames']

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
    max_jacobian_condition: float = MAX_JACOBIAN_CONDITION  # of J (m, rad) (S21)
    u_joint_max_angle: float | None = None          # rad, largest |theta_1|, |theta_2| (S5)
    spherical_joint_max_angle: float | None = None  # rad, largest angle of u_i from the
    #                                                 platform's z axis


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
                                  else np.asarray(inertia, dtype=float).ravel().tolist()})
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
# From the parameter file's layout (stewart.md, "The parameter file"): its
# sections and keys, and each value's bounds, are the declarations'
# (.parameters.PARAMETER_SPECS)
# ---------------------------------------------------------------------------

def _keys(section: str) -> tuple[set[str], set[str]]:
    """(the keys ``section`` may give, those it must) by the declarations: a key
    is required if a parameter under it is; a section none of whose keys is
    required (payload, friction) is given whole.
    """
    prefix = '' if section == 'parameters' else section + '.'
    keys: set[str] = set()
    required: set[str] = set()
    for spec in PARAMETER_SPECS:
        if spec.name.startswith(prefix):
            key = spec.name[len(prefix):].split('.')[0]
            keys.add(key)
            if spec.required:
                required.add(key)
    return keys, required or keys


def _key(section: str, name: str) -> str:
    """The dotted name of ``name`` in ``section`` ('parameters': the top level)."""
    return name if section == 'parameters' else f'{section}.{name}'


def _section(name: str, value: object) -> Mapping:
    if not isinstance(value, Mapping):
        raise ModelValueError(name, f'{name} must be a mapping, got {value!r:.100}')
    keys, required = _keys(name)
    unknown = sorted(map(str, set(value) - keys))
    if unknown:
        raise ModelValueError(_key(name, unknown[0]),
                              f'{name}: unknown key(s) {", ".join(unknown)}')
    missing = sorted(required - set(value))
    if missing:
        raise ModelValueError(_key(name, missing[0]),
                              f'{name}: missing key(s) {", ".join(missing)}')
    return value


def _value(key: str, value: object) -> Any:
    """``value`` of the parameter ``key`` within its declaration (the one check,
    :func:`~flight_sim_dynamics.core.parameter_spec.check_value`), canonical;
    ModelValueError naming the key.
    """
    try:
        return check_value(SPECS[key], value)
    except ModelValueError as exc:
        raise ModelValueError(key, f'{key}: {exc}') from None


def _array(key: str, value: object) -> np.ndarray:
    return np.array(_value(key, value), dtype=float)


def _rigid(name: str, d: object) -> RigidBody:
    d = _section(name, d)
    mass = _value(f'{name}.mass', d['mass'])
    inertia = _array(f'{name}.inertia', d['inertia']).reshape(3, 3)
    scale = max(1.0, float(np.abs(inertia).max()))
    if not np.allclose(inertia, inertia.T, rtol=0.0, atol=1e-12 * scale):
        raise ModelValueError(f'{name}.inertia', f'{name}.inertia must be symmetric, got '
                              f'{inertia.ravel().tolist()}')
    eig = np.linalg.eigvalsh(inertia)
    if eig[0] < -1e-12 * scale or eig[2] > eig[0] + eig[1] + 1e-9 * scale:
        raise ModelValueError(f'{name}.inertia', f'{name}.inertia is not a body\'s inertia '
                              f'(principal moments {eig.tolist()}: each must be >= 0 and at '
                              'most the sum of the others)')
    if mass == 0.0 and np.any(inertia != 0.0):
        raise ModelValueError(f'{name}.inertia',
                              f'{name}.inertia must be zero for a body of no mass')
    return RigidBody(mass, _array(f'{name}.com', d['com']), inertia)


def _leg(name: str, d: object) -> LegBody:
    d = _section(name, d)
    return LegBody(*(_value(f'{name}.{k}', d[k]) for k in
                     ('mass', 'com_distance', 'inertia_across', 'inertia_along')))


def _points(key: str, value: object) -> np.ndarray:
    return _array(key, value).reshape(6, 3)


def _limits(d: object) -> Limits:
    d = _section('limits', d)
    # an absent joint-angle limit may be written as null (no limit)
    out = {k: _value(f'limits.{k}', v) for k, v in d.items()
           if v is not None or SPECS[f'limits.{k}'].required}
    if not out['length_max'] > out['length_min']:
        raise ModelValueError('limits.length_max', 'limits.length_max must be > '
                              f"{out['length_min']:g} m (limits.length_min), got "
                              f"{out['length_max']:g}")
    return Limits(**out)


def _friction(d: object) -> Friction:
    d = _section('friction', d)
    return Friction(*(_value(f'friction.{k}', d[k]) for k in
                      ('viscous', 'coulomb', 'smoothing_velocity')))


def from_dict(params: Mapping, effects: Effects | None = None) -> StewartModel:
    """The model of a parameter file's ``ros__parameters``, nested (the
    configuration picks the node's sections). ``payload`` and ``friction`` may
    be left out (zero).
    ``effects`` are the effects of the scene the file names (the caller
    resolves the name); left out, they are scene full's, :class:`Effects`'
    defaults, and any other scene name is a ValueError.
    """
    params = _section('parameters', params)
    name = _value('machine', params['machine'])
    if not name:
        raise ModelValueError('machine', 'machine must be a name, got an empty string')
    scene = _value('scene', params.get('scene', 'full'))
    if not scene:
        raise ModelValueError('scene', 'scene must be a name, got an empty string')
    if effects is None and scene != 'full':
        raise ModelValueError('scene', f"scene '{scene}': pass its effects (scene full's are "
                              'the defaults)')
    geo = _section('geometry', params['geometry'])
    base = _points('geometry.base_joints', geo['base_joints'])
    plat = _points('geometry.platform_joints', geo['platform_joints'])
    axes = _points('geometry.base_axes', geo['base_axes'])
    home = _array('geometry.home', geo['home'])
    with np.errstate(over='ignore', invalid='ignore'):    # finite numbers whose norms overflow
        norms = np.linalg.norm(axes, axis=1)
        reach = np.linalg.norm(home + plat - base, axis=1)
    if not np.all(np.isfinite(norms)):
        raise ModelValueError('geometry.base_axes', 'geometry.base_axes: too large (the length '
                              'of an axis is beyond the floating-point range)')
    if not np.all(np.isfinite(reach)):
        key = max((('geometry.base_joints', base), ('geometry.platform_joints', plat),
                   ('geometry.home', home)), key=lambda kv: float(np.abs(kv[1]).max()))[0]
        raise ModelValueError(key, f'{key}: too large (a leg\'s length at home is beyond '
                              'the floating-point range)')
    if np.any(norms < 1e-9):
        raise ModelValueError('geometry.base_axes', 'geometry.base_axes: axis of leg '
                              f'{int(np.argmin(norms)) + 1} is zero')
    bodies = _section('bodies', params['bodies'])
    payload = params.get('payload', {'mass': 0.0, 'com': [0.0] * 3, 'inertia': [0.0] * 9})
    model = StewartModel(
        name=name, base_joints=base, platform_joints=plat, base_axes=axes / norms[:, None],
        home=home, gravity=_value('gravity', params['gravity']),
        platform=_rigid('bodies.platform', bodies['platform']),
        cylinder=_leg('bodies.cylinder', bodies['cylinder']),
        rod=_leg('bodies.rod', bodies['rod']),
        payload=_rigid('payload', payload),
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
            raise ModelValueError('geometry.home',
                                  f'geometry.home: leg {i + 1} has zero length at home')
        s2 = float(model.base_axes[i] @ d[i] / L[i])
        if 1.0 - s2 * s2 < U_JOINT_TOLERANCE ** 2:
            raise ModelValueError('geometry.base_axes', f'geometry.base_axes: leg {i + 1} lies '
                                  'along its U-joint\'s first axis at home (singular joint)')

