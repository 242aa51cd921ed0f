"""The model, constant (Pinocchio's *model*): geometry (eq. 7-8), mass properties
(eq. 18-19), gravity and the constants of the central configuration (``beta0``,
the slider offset ``s`` = D2E2, the joint zeros: the ``alpha_i`` of eq. 1-2).
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace
from types import MappingProxyType
from typing import Mapping

import numpy as np

from ...core.effects import Effects

#: Order of the geometry constants (paper's symbols, Section 3 application data).
GEOMETRY_KEYS = ('d1', 'd2', 'd3', 'd4', 'd5', 'l1', 'l2', 'l3', 'l4', 'l5', 'l6',
                 'b', 'h', 'h_G', 's_A', 's_B', 's_C')

#: The bodies that carry mass, in the order chains A, B, C, cranks D, E.
BODY_NAMES = ('cylinder_a', 'piston_a', 'rod', 'platform',
              'cylinder_b', 'piston_b', 'cylinder_c', 'piston_c',
              'crank_d', 'crank_e')

#: The 12 joint variables of eq. (13), in the paper's order.
JOINT_NAMES = ('phi_10_A', 'lambda_21_A', 'phi_32_A',
               'phi_10_B', 'phi_21_B', 'lambda_32_B',
               'phi_10_C', 'phi_21_C', 'lambda_32_C',
               'phi_10_D', 'phi_10_E', 'lambda_E2')

#: Indices of the three actuated prismatic joints (A2, B3, C3) in eq. (13).
ACTUATED_JOINTS = (1, 5, 8)

LEG_NAMES = ('leg_a', 'leg_b', 'leg_c')


@dataclass(frozen=True)
class Geometry:
    """Lengths of the paper (m); see Fig. 2 and the application data."""

    d1: float
    d2: float
    d3: float
    d4: float
    d5: float
    l1: float
    l2: float
    l3: float
    l4: float
    l5: float
    l6: float
    b: float
    h: float
    h_G: float
    s_A: float
    s_B: float
    s_C: float

    # Constant points of eq. (8), fixed frame, paper axes (x0 fwd, y0 up, z0 right).
    @property
    def A1(self) -> np.ndarray:
        return np.zeros(3)

    @property
    def E1(self) -> np.ndarray:
        return np.array([self.d2, 0.0, 0.0])

    @property
    def D1(self) -> np.ndarray:
        return np.array([self.d2 + self.d3, 0.0, 0.0])

    @property
    def F(self) -> np.ndarray:
        return np.array([self.d2 + self.d3 + self.d4, 0.0, 0.0])

    @property
    def B1(self) -> np.ndarray:
        return self.F + np.array([0.0, 0.0, self.d5])

    @property
    def C1(self) -> np.ndarray:
        return self.F - np.array([0.0, 0.0, self.d5])

    @property
    def L0(self) -> np.ndarray:
        """Leg lengths at zero stroke: s_A + l2, s_B + l4, s_C + l4 (eq. 8)."""
        return np.array([self.s_A + self.l2, self.s_B + self.l4, self.s_C + self.l4])


@dataclass(frozen=True)
class Body:
    """Mass properties of one body, in its body frame (see the YAML header)."""

    mass: float
    com: np.ndarray       # (3,) centre of mass in the body frame, m
    inertia: np.ndarray   # (3, 3) about the centre of mass, body frame, kg m^2
    com_t: tuple = field(init=False, repr=False, compare=False)      # plain-float copies
    inertia_t: tuple = field(init=False, repr=False, compare=False)  # for the solver

    def __post_init__(self) -> None:
        object.__setattr__(self, 'com_t', tuple(float(x) for x in self.com))
        object.__setattr__(self, 'inertia_t',
                           tuple(tuple(float(x) for x in row) for row in self.inertia))


@dataclass(frozen=True)
class Friction:
    """Actuator friction (used when the scene enables it): per actuator A, B, C,
    f = viscous x rate + coulomb x tanh(rate / smoothing_velocity).
    """

    viscous: tuple = (0.0, 0.0, 0.0)      # N s/m
    coulomb: tuple = (0.0, 0.0, 0.0)      # N
    smoothing_velocity: float = 1e-3      # m/s


@dataclass(frozen=True)
class Limits:
    """Actuator limits and near-singularity thresholds: a solve beyond them gets
    the status ``limit`` or ``near_singular`` (parameters ``limits.*``).
    """

    stroke_min: float = -0.3                 # m, lowest stroke L - L0
    stroke_max: float = 0.6                  # m, highest stroke
    max_speed: float = 1.0                   # m/s, largest |dL/dt|
    max_force: float = 2000.0                # N, largest |f|
    max_kinematic_condition: float = 100.0   # of Q's pivot blocks
    max_jacobian_condition: float = 100.0    # of the scaled actuator Jacobian


@dataclass(frozen=True)
class CentralConfiguration:
    """Constants fixed once at the central configuration (q = 0)."""

    beta0: float              # parasitic angle at q = 0, rad
    s: float                  # D2E2 at q = 0: the paper's unstated s, m
    joint_zero: np.ndarray    # (12,) raw joint angles at q = 0 (the alpha_i offsets)
    length: np.ndarray        # (3,) leg lengths at q = 0, m


@dataclass(frozen=True)
class Model:
    """Everything constant about the mechanism. Build it with
    :func:`flight_sim_dynamics.load_model` (validated), never by hand.
    """

    geometry: Geometry
    bodies: Mapping[str, Body]
    gravity: float
    central: CentralConfiguration
    values: Mapping[str, object] = field(default_factory=dict)  # the validated flat parameters
    effects: Effects = field(default_factory=Effects)           # what the solver computes
    scene: str = 'full'                                         # name of the scene
    payload: Body | None = None                                 # cab and occupants (platform frame)
    friction: Friction = field(default_factory=Friction)
    limits: Limits = field(default_factory=Limits)

    def with_effects(self, effects: Effects, scene: str | None = None) -> 'Model':
        """The same mechanism simulating another set of effects."""
        return replace(self, effects=effects,
                       scene=scene if scene is not None else 'custom')

    def __post_init__(self) -> None:
        object.__setattr__(self, 'bodies', MappingProxyType(dict(self.bodies)))
        object.__setattr__(self, 'values', MappingProxyType(dict(self.values)))
