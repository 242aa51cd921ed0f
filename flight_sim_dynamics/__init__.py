"""flight_sim_dynamics: inverse kinematics and dynamics of the 3-DOF parallel
flight simulator of Staicu, Ocnarescu and Ungureanu (2013), by the paper's
recursive matrix method, with a ROS 2 node around it.

Python API (model/data style)::

    import flight_sim_dynamics as fsd
    model = fsd.load_model()                 # packaged defaults, or a YAML path
    sol = fsd.solve(model, q, qd, qdd)       # one cycle: sol.length, .force, ...
    batch = fsd.solve_batch(model, Q, Qd, Qdd)   # N x 3 arrays
    fd = fsd.forward_dynamics(model, q, qd, force)   # fd.acceleration, fd.status
    sim = fsd.simulate(model, reference=motion, feedforward=model)   # the twin

The numerical core imports numpy only; rclpy is needed by the node alone.
"""
from .core import trajectories
from .core.forward_dynamics import ForwardDynamics, forward_dynamics
from .core.forward_kinematics import ForwardSolution, forward_kinematics
from .core.kinematics import UnreachablePoseError
from .core.model import JOINT_NAMES, LEG_NAMES, Model
from .config.parameters import ParameterError, load_model
from .core.simulation import Servo, Simulation, simulate
from .core.solver import Solution, solve, solve_batch
from .core.status import Status

__all__ = ['load_model', 'solve', 'solve_batch', 'forward_kinematics', 'forward_dynamics',
           'simulate', 'Simulation', 'Servo', 'Model', 'Solution', 'ForwardSolution',
           'ForwardDynamics', 'Status', 'ParameterError',
           'UnreachablePoseError', 'JOINT_NAMES', 'LEG_NAMES', 'trajectories']
__version__ = '0.1.0'
