"""The hexapod as the shared layer sees it (:class:`flight_sim_dynamics.core.machine.Machine`)."""
from __future__ import annotations

import numpy as np

from ...core.effects import EFFECT_NAMES
from ...core.machine import ActuatorLimits, Machine
from . import kernel
from .drawing import drawing
from .dynamics import has_inertia
from .forward_dynamics import affine_terms, forward_dynamics
from .kinematics import forward_kinematics
from .limits import limit_usage, tightened
from .model import LEG_NAMES, StewartModel, from_dict
from .motions import MOTIONS
from .parameters import PARAMETER_NAMES, PARAMETER_SPECS
from .solver import COORDINATES, solve, solve_batch
from .workspace import OPTIONS as WORKSPACE_OPTIONS
from .workspace import survey

#: The joint variables of each leg, in the order of a solution's ``joints``
#: (U-joint angles theta_1, theta_2 (S5), the prismatic joint's length L).
JOINT_NAMES = tuple(f'{leg}_{variable}' for leg in LEG_NAMES
                    for variable in ('theta_1', 'theta_2', 'length'))


def actuator_limits(model: StewartModel) -> ActuatorLimits:
    """Strokes from the length limits and each leg's length at home."""
    lim = model.limits
    return ActuatorLimits(stroke_min=lim.length_min - model.home_lengths,
                          stroke_max=lim.length_max - model.home_lengths,
                          max_speed=lim.max_speed, max_force=lim.max_force)


def affine_parts(model: StewartModel, q, qd) -> tuple[np.ndarray, np.ndarray, object]:
    """(M, b, the solve at qdd = 0) of f = M qdd + b (S10)-(S21), :func:`.affine_terms`."""
    terms = affine_terms(model, q, qd)
    return terms.M, terms.b, terms.solution


def require_inertia(model: StewartModel) -> None:
    """ValueError unless the model's scene moves some body (M != 0)."""
    if not has_inertia(model):
        raise ValueError(f"scene '{model.scene}' computes no inertia (enabled effects: "
                         f"{', '.join(model.effects.enabled()) or 'none'}), so forces do not "
                         'determine accelerations; forward dynamics and simulation need a scene '
                         'with inertia, e.g. full')


MACHINE = Machine(
    name='stewart', model_type=StewartModel, coordinates=COORDINATES,
    units=('m', 'm', 'm', 'rad', 'rad', 'rad'), legs=LEG_NAMES, joints=JOINT_NAMES,
    solve=solve, solve_batch=solve_batch, forward_kinematics=forward_kinematics,
    forward_dynamics=forward_dynamics, actuator_limits=actuator_limits,
    limit_usage=limit_usage, tightened=tightened, parameters=PARAMETER_NAMES, from_params=from_dict,
    parameter_files=('stewart_6dof', 'stewart_tsai2000'),
    title='6-DOF hexapod', leg_labels=tuple(str(i) for i in range(1, len(LEG_NAMES) + 1)),
    sample_fields=('jacobian_condition',), motions=MOTIONS, examples=tuple(MOTIONS),
    # what a user sees beyond numbers
    drawing=drawing, workspace=survey, workspace_options=WORKSPACE_OPTIONS,
    # what each effect costs: a hexapod has no cranks
    effects=tuple(e for e in EFFECT_NAMES if e != 'crank_inertia'),
    bench_motions=('gentle', 'cueing', 'violent'), kernel_enabled=kernel.enabled,
    # simulation and the twin
    affine_terms=affine_parts, require_inertia=require_inertia,
    integrate_rows=kernel.integrate_rows,
    # the dynamics node
    parameter_specs=PARAMETER_SPECS,
    home_parameters=('geometry.base_joints', 'geometry.platform_joints', 'geometry.base_axes',
                     'geometry.home', 'limits.max_jacobian_condition'),
    # the demo planner: a slow tour, then motion cueing
    planner_motions=('gentle', 'cueing'), planner_example='cueing')
