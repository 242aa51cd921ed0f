"""flight_sim_dynamics: inverse kinematics and dynamics of the 3-DOF parallel
flight simulator of Staicu, Ocnarescu and Ungureanu (2013), by the paper's
recursive matrix method, and of 6-UPS Stewart-Gough hexapods (machines are
plugins: the entry-point group ``flight_sim_dynamics.machines``), with a
motion-cueing planner and ROS 2 nodes for every registered machine.

Python API (model/data style)::

    import flight_sim_dynamics as fsd
    model = fsd.load_model()                 # packaged defaults, or a YAML path / packaged name
    sol = fsd.solve(model, q, qd, qdd)       # one cycle: sol.length, .force, ...
    batch = fsd.solve_batch(model, Q, Qd, Qdd)   # N x 3 arrays
    fd = fsd.forward_dynamics(model, q, qd, force)   # fd.acceleration, fd.status
    sim = fsd.simulate(model, reference=motion, feedforward=model)   # the twin

    hexa = fsd.load_model('stewart_6dof')    # a packaged file by its name (config/<name>.yaml)
    sol = fsd.solve(hexa, q6, qd6, qdd6)     # the same calls, six numbers each
    fsd.machine_of(hexa).coordinates         # surge, sway, heave, roll, pitch, yaw

The numerical core imports numpy only; rclpy is needed by the node alone.
"""
import importlib
from typing import Any

#: The public API, name -> module: imported on first use, so that importing
#: the package is quick (the command line's Ctrl-C handler is in place before numpy loads).
_API = {'trajectories': '.machines.staicu.trajectories',
        'ForwardDynamics': '.machines.staicu.forward_dynamics',
        'forward_dynamics': '.machines.api',
        'ForwardSolution': '.core.forward',
        'forward_kinematics': '.machines.api', 'machine_of': '.machines.api',
        'Machine': '.core.machine', 'UnreachablePoseError': '.machines.staicu.kinematics',
        'JOINT_NAMES': '.machines.staicu.model', 'LEG_NAMES': '.machines.staicu.model',
        'Model': '.machines.staicu.model', 'ParameterError': '.config.parameters',
        'load_model': '.config.machine_files', 'Servo': '.core.servo',
        'servo_for_bandwidth': '.machines.api',
        'Simulation': '.core.simulation', 'simulate': '.machines.api',
        'Solution': '.machines.staicu.solver', 'solve': '.machines.api',
        'solve_batch': '.machines.api', 'StewartModel': '.machines.stewart.model',
        'Status': '.core.status'}

__all__ = list(_API)
__version__ = '0.1.0'


def __getattr__(name: str) -> Any:
    if name not in _API:
        raise AttributeError(f'module {__name__!r} has no attribute {name!r}')
    module = importlib.import_module(_API[name], __name__)
    value = module if name == 'trajectories' else getattr(module, name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
