"""The declarations of a hexapod's parameters (docs/design/stewart.md, "The
parameter file"): type, unit, meaning and bounds, the one place they are
written: the loaders (config/machine_files.py) and :func:`.model.from_dict`
check each value against them
(:func:`~flight_sim_dynamics.core.parameter_spec.check_value`), and the file's
layout (its sections, the keys each must give) is read from their names. The
defaults are the packaged file's (config/stewart_6dof.yaml), or the builder's
where it has one; the joint-angle limits have none (no limit unless given).
Every number is bounded (core/parameter_spec.py's physical bounds: 100 t,
100 m, ...), so that no product of the solver overflows. What the builder
checks on the whole (symmetric inertia, length_max > length_min, a regular
home) it checks.
"""
from __future__ import annotations

import math

from ...core.parameter_spec import (MAX_COM, MAX_CONDITION, MAX_FORCE, MAX_FRICTION,
                                    MAX_GRAVITY, MAX_INERTIA, MAX_LENGTH, MAX_MASS, MAX_SPEED,
                                    ParamSpec)

MAX_PATH = 4096     # characters of a scene file's path
#: |component| of a U-joint axis: any length is normalised, none overflows
MAX_AXIS = 1.0e3
#: The default near-singularity threshold on the 2-norm condition of J (S21).
MAX_JACOBIAN_CONDITION = 100.0


def _xyz(what: str, n: int) -> str:
    return f'{what}, x y z of legs 1-{n // 3} in a row'


def _spec(name: str, kind: str, description: str, unit: str = '', minimum: float | None = None,
          exclusive: bool = False, maximum: float | None = None, length: int | None = None,
          required: bool = True) -> ParamSpec:
    return ParamSpec(name, kind, None, description, unit, minimum=minimum, maximum=maximum,
                     exclusive_minimum=exclusive, length=length, required=required)


def _rigid(prefix: str, what: str, mass_minimum_exclusive: bool, required: bool) -> list:
    return [
        _spec(f'{prefix}.mass', 'double', f'mass of the {what}', 'kg', 0.0,
              mass_minimum_exclusive, MAX_MASS, required=required),
        _spec(f'{prefix}.com', 'double_array', f'centre of mass of the {what}, platform frame',
              'm', -MAX_COM, maximum=MAX_COM, length=3, required=required),
        _spec(f'{prefix}.inertia', 'double_array', f'inertia tensor of the {what} about its '
              'centre of mass, platform axes, row-major 3x3 (symmetric, a body\'s)', 'kg m^2',
              -MAX_INERTIA, maximum=MAX_INERTIA, length=9, required=required)]


def _leg(body: str, end: str) -> list:
    prefix = f'bodies.{body}'
    return [
        _spec(f'{prefix}.mass', 'double', f'mass of each leg\'s {body}', 'kg', 0.0,
              maximum=MAX_MASS),
        _spec(f'{prefix}.com_distance', 'double', f'distance of the {body}\'s centre of mass '
              f'from {end} along the leg', 'm', 0.0, maximum=MAX_COM),
        _spec(f'{prefix}.inertia_across', 'double', f'inertia of the {body} about an axis '
              'across the leg through its centre of mass', 'kg m^2', 0.0, maximum=MAX_INERTIA),
        _spec(f'{prefix}.inertia_along', 'double', f'inertia of the {body} about the leg axis',
              'kg m^2', 0.0, maximum=MAX_INERTIA)]


#: Every parameter of a hexapod's file but the node's own (config/schema.py's NODE_PARAMETERS).
PARAMETER_SPECS: tuple[ParamSpec, ...] = tuple([
    _spec('machine', 'string', 'the machine the parameter file describes (a packaged one, '
          'e.g. stewart_6dof, or stewart: a hexapod of one\'s own, given whole)'),
    _spec('gravity', 'double', 'gravitational acceleration, acting along -z (down)', 'm/s^2',
          0.0, maximum=MAX_GRAVITY),
    ParamSpec('scene', 'string', 'full', 'effects to simulate: a scene name from config/scenes '
              '(full, quasi_static, platform_only, payload) or the path of a scene YAML file',
              required=False, max_length=MAX_PATH),
    _spec('geometry.base_joints', 'double_array', _xyz('base joints B_i, base frame', 18),
          'm', -MAX_LENGTH, maximum=MAX_LENGTH, length=18),
    _spec('geometry.platform_joints', 'double_array',
          _xyz('platform joints p_i, platform frame', 18), 'm', -MAX_LENGTH,
          maximum=MAX_LENGTH, length=18),
    _spec('geometry.base_axes', 'double_array', _xyz('first axes a_1,i of the U-joints, base '
          'frame (normalised; none zero)', 18), '1', -MAX_AXIS, maximum=MAX_AXIS, length=18),
    _spec('geometry.home', 'double_array', 'the platform origin at home (q = 0), base frame; '
          'the home pose must solve ok or limit (not near_singular: legs in the base plane '
          'are refused)', 'm', -MAX_LENGTH, maximum=MAX_LENGTH, length=3),
    *_rigid('bodies.platform', 'platform', True, True),
    *_leg('cylinder', 'its base joint B_i'),
    *_leg('rod', 'its platform joint P_i'),
    *_rigid('payload', 'payload (0: none)', False, False),
    _spec('friction.viscous', 'double_array', 'viscous friction coefficient of legs 1-6',
          'N s/m', 0.0, maximum=MAX_FRICTION, length=6, required=False),
    _spec('friction.coulomb', 'double_array', 'Coulomb (dry) friction force of legs 1-6', 'N',
          0.0, maximum=MAX_FRICTION, length=6, required=False),
    _spec('friction.smoothing_velocity', 'double', 'rate below which Coulomb friction is '
          'smoothed: F_c tanh(rate / v_s)', 'm/s', 0.0, True, 10.0, required=False),
    _spec('limits.length_min', 'double', 'shortest allowed leg, joint centre to joint centre',
          'm', 0.0, True, MAX_LENGTH),
    _spec('limits.length_max', 'double', 'longest allowed leg; must be > limits.length_min',
          'm', 0.0, True, MAX_LENGTH),
    _spec('limits.max_speed', 'double', 'largest allowed leg speed |dL/dt|', 'm/s', 0.0, True,
          MAX_SPEED),
    _spec('limits.max_force', 'double', 'largest allowed actuator force |f|', 'N', 0.0, True,
          MAX_FORCE),
    ParamSpec('limits.max_jacobian_condition', 'double', MAX_JACOBIAN_CONDITION,
              'status near_singular beyond this 2-norm condition number of J (m, rad); the '
              'home pose must be below it', '1', minimum=1.0, maximum=MAX_CONDITION,
              required=False),
    _spec('limits.u_joint_max_angle', 'double', 'largest U-joint angle |theta_1|, |theta_2| '
          '(absent: no limit)', 'rad', 0.0, True, math.pi, required=False),
    _spec('limits.spherical_joint_max_angle', 'double', 'largest angle of a leg from the '
          'platform\'s z axis (absent: no limit)', 'rad', 0.0, True, math.pi, required=False),
])
#: Their names (dotted, as ROS 2 flattens a file's sections).
PARAMETER_NAMES: frozenset[str] = frozenset(spec.name for spec in PARAMETER_SPECS)
#: The declarations by name.
SPECS = {spec.name: spec for spec in PARAMETER_SPECS}
