"""The 3-DOF flight simulator as the shared layer sees it
(:class:`flight_sim_dynamics.core.machine.Machine`).
"""
from __future__ import annotations

import numpy as np

from ...core.machine import ActuatorLimits, Machine
from . import kernel
from .forward_dynamics import affine_terms, forward_dynamics, require_inertia
from .forward_kinematics import forward_kinematics
from .limits import limit_usage, tightened
from .mechanism import drawing
from .model import GEOMETRY_KEYS, JOINT_NAMES, LEG_NAMES, Model
from .motions import MOTIONS, PLANNER_MOTIONS, TEST_MOTIONS
from .parameters import PARAMETER_FILES, PARAMETER_NAMES, PARAMETER_SPECS, from_params
from .solver import Solution, solve, solve_batch
from .trajectories import PAPER_EXAMPLES
from .workspace import OPTIONS as WORKSPACE_OPTIONS
from .workspace import survey


def actuator_limits(model: Model) -> ActuatorLimits:
    """The 3-DOF machine's limits (parameters ``limits.*``), the same for every leg."""
    lim, legs = model.limits, len(LEG_NAMES)
    return ActuatorLimits(stroke_min=np.full(legs, lim.stroke_min),
                          stroke_max=np.full(legs, lim.stroke_max),
                          max_speed=lim.max_speed, max_force=lim.max_force)


def parasitic_pitch(solution: Solution) -> float:
    """The platform's REP-103 pitch at a solution: -beta (eq. 8)."""
    return -solution.beta


#: The 3-DOF flight simulator of Staicu, Ocnarescu and Ungureanu (the default).
MACHINE = Machine(
    name='flight_simulator_3dof', model_type=Model, coordinates=('surge', 'heave', 'roll'),
    units=('m', 'm', 'rad'), legs=LEG_NAMES, joints=JOINT_NAMES, solve=solve,
    solve_batch=solve_batch, forward_kinematics=forward_kinematics,
    forward_dynamics=forward_dynamics, actuator_limits=actuator_limits,
    limit_usage=limit_usage, tightened=tightened,
    # its parameter files (config/flight_sim_dynamics.yaml; they name no machine)
    parameters=PARAMETER_NAMES | {'machine'}, from_params=from_params,
    parameter_files=PARAMETER_FILES,
    title='3-DOF flight simulator', leg_labels=('a', 'b', 'c'),
    sample_fields=('beta', 'kinematic_condition', 'jacobian_condition'),
    costly_fields=('cond',), motions=MOTIONS, examples=tuple(PAPER_EXAMPLES),
    example_figures={name: f"the paper's Figs. {f} and {f + 1}"
                     for name, f in zip(PAPER_EXAMPLES, (3, 5, 7))},
    # what a user sees beyond numbers
    drawing=drawing, workspace=survey, workspace_options=WORKSPACE_OPTIONS,
    # what each effect costs
    bench_motions=TEST_MOTIONS, kernel_enabled=kernel.enabled,
    # simulation and the twin
    affine_terms=affine_terms, require_inertia=require_inertia,
    integrate_rows=kernel.integrate_rows,
    # the dynamics node: its parameters; the mechanism pitches the platform by -beta
    # (REP pitch)
    parameter_specs=PARAMETER_SPECS, parasitic={'pitch': parasitic_pitch},
    home_parameters=(*(f'geometry.{key}' for key in GEOMETRY_KEYS),
                     'limits.max_kinematic_condition', 'limits.max_jacobian_condition'),
    # the demo planner
    planner_motions=PLANNER_MOTIONS, planner_example='general')
