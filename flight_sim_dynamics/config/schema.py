"""The schema: the one declaration of every parameter (name, kind, default,
unit, physical bounds, meaning), for the solver and the node alike.

Model parameters are the machine's, each machine declaring its own
(:attr:`~flight_sim_dynamics.core.machine.Machine.parameter_specs`): those of
the default machine, whose files name no machine, are :func:`model_parameters`
(``MODEL_PARAMETERS``, ``ALL_PARAMETERS`` with the node's, ``SPECS`` by name:
read from the registry when asked for); node parameters tune the ROS 2 node and
are every machine's. Every number is bounded to a physical or sensible range (a
centre of mass at 1e300 m is not a mechanism), every string in length.
"""
from __future__ import annotations

from typing import Any, Callable, Mapping

from ..core.parameter_spec import ParamSpec
from ..machines import default_machine

# Physical bounds shared by every body (and the payload): MAX_MASS, MAX_COM,
# MAX_INERTIA, MAX_LENGTH are every machine's (core/parameter_spec.py).
MAX_NAME = 256              # characters of a frame id
MAX_PATH = 4096             # characters of a file path (PATH_MAX on Linux)



# Node parameters: declared by the node, also accepted by load_model (one file serves both).
# (QoS: rclpy's read-only qos_overrides.<topic>.* parameters, declared by the node's endpoints.)
NODE_PARAMETERS: tuple[ParamSpec, ...] = (
    ParamSpec('limits.warn_fraction', 'double', 0.9,
              'status WARN when a limit of the machine (a stroke, speed, force, a joint '
              'angle where limited) is used to at least this fraction (stroke: of the half-range '
              'around its middle)', '1',
              minimum=0.0, maximum=1.0),
    ParamSpec('input.max_linear_acceleration', 'double', 50.0,
              'setpoints whose surge, sway or heave acceleration (given or estimated; those '
              'the machine follows) exceeds this are rejected as absurd', 'm/s^2',
              minimum=0.0, exclusive_minimum=True, maximum=1.0e6),
    ParamSpec('input.max_angular_acceleration', 'double', 100.0,
              'setpoints whose angular acceleration (a component of accel_setpoint\'s angular '
              'part, or an estimated Euler-angle acceleration; those the machine follows) '
              'exceeds this are rejected as absurd', 'rad/s^2',
              minimum=0.0, exclusive_minimum=True, maximum=1.0e6),
    ParamSpec('input.quaternion_tolerance', 'double', 1.0e-3,
              'largest accepted | |q| - 1 | of an orientation quaternion (it is then '
              'normalised); beyond it the setpoint is rejected', '1',
              minimum=0.0, maximum=0.5),
    ParamSpec('input.position_tolerance', 'double', 1.0e-3,
              'a position the machine does not follow (a component of position, and of the '
              'linear part of twist and acceleration per s, s^2, that is none of its '
              'coordinates) beyond this is reported as motion the machine cannot follow, then '
              'ignored', 'm',
              minimum=0.0, maximum=10.0),
    ParamSpec('input.angle_tolerance', 'double', 1.0e-3,
              'an angle the machine does not follow (one that is none of its coordinates, '
              'other than zero or the value the machine moves it to by itself) beyond this is '
              'reported as motion the machine cannot follow, then ignored', 'rad',
              minimum=0.0, maximum=3.2),
    ParamSpec('input.max_future', 'double', 1.0,
              'setpoints stamped more than this ahead of the node\'s clock are rejected as '
              'future_stamp (0: no check; the check also waits for a sim-time clock\'s first '
              '/clock)', 's', minimum=0.0, maximum=86400.0),
    ParamSpec('input.restart_jump', 'double', 1.0,
              'three setpoints in a row stamped more than this before the last answered one '
              'are a planner restart: the stamp and estimator history is reset; on the other '
              'input only once the one that carried the last answered setpoint has been '
              'silent this long (0: never)',
              's', minimum=0.0, maximum=86400.0),
    ParamSpec('input.max_points', 'integer', 1000,
              'most points in one platform_setpoint message; a longer message is rejected '
              'whole (undecoded when its size alone shows it)', '1', minimum=1, maximum=100000),
    ParamSpec('sync.wait', 'double', 0.05,
              'longest wait for the twist and acceleration carrying a pose\'s stamp before '
              'the setpoint is solved without them (they are then estimated)', 's',
              minimum=0.0, maximum=10.0),
    ParamSpec('sync.max_pending', 'integer', 64,
              'most setpoint stamps waiting for their other messages at once', '1',
              minimum=1, maximum=100000),
    ParamSpec('estimator.method', 'string', 'backward2',
              'finite differences for missing rates and accelerations: backward (2-point, '
              'first order) or backward2 (3-point BDF2, second order)', '',
              choices=('backward', 'backward2')),
    ParamSpec('estimator.max_gap', 'double', 0.5,
              'a gap between setpoint stamps longer than this restarts the estimator '
              '(motion assumed to start from rest)', 's',
              minimum=0.0, exclusive_minimum=True, maximum=3600.0),
    ParamSpec('diagnostics.period', 'double', 1.0,
              'period of the /diagnostics message', 's',
              minimum=0.01, maximum=3600.0),
    ParamSpec('diagnostics.hardware_id', 'string', 'flight_sim_dynamics',
              'hardware_id of the node\'s /diagnostics status (its name is the node\'s fully '
              'qualified name plus ": inverse dynamics")', '', max_length=MAX_NAME),
    ParamSpec('diagnostics.log_throttle', 'double', 2.0,
              'at most one log line per rejection reason per this period', 's',
              minimum=0.0, maximum=3600.0),
    ParamSpec('autostart', 'bool', True,
              'configure and activate at start-up (a bad parameter then ends the process, '
              'exit 2); false: start unconfigured and wait for a lifecycle manager or '
              '`ros2 lifecycle set` (a failing configure then leaves it unconfigured)', ''),
    ParamSpec('output.frame_id', 'string', 'simulator_base',
              'header.frame_id of actuator_states: the REP-103 simulator base frame, the '
              'setpoints\' frame (docs/node.md); leg lengths are frame-free scalars', '',
              max_length=MAX_NAME),
    ParamSpec('output.joint_states_frame_id', 'string', 'simulator_base',
              'header.frame_id of joint_states (the machine\'s joint variables)', '',
              max_length=MAX_NAME),
    ParamSpec('output.markers_rate', 'double', 30.0,
              "rate of the machine's markers (visualization_msgs/MarkerArray of "
              'ros/markers.py, in output.frame_id); 0 = none', 'Hz',
              minimum=0.0, maximum=1000.0),
)



def model_parameters() -> tuple[ParamSpec, ...]:
    """The model parameters of the default machine (:func:`.machines.default_machine`:
    a file without a ``machine:`` line is its), its :attr:`Machine.parameter_specs`.
    """
    return default_machine().parameter_specs


def all_parameters() -> tuple[ParamSpec, ...]:
    """The default machine's model parameters, then the node's."""
    return model_parameters() + NODE_PARAMETERS


def specs() -> Mapping[str, ParamSpec]:
    """:func:`all_parameters` by name."""
    return {spec.name: spec for spec in all_parameters()}


def defaults() -> dict[str, Any]:
    """The packaged default value of every parameter, by dotted name."""
    return {spec.name: (list(spec.default) if isinstance(spec.default, list) else spec.default)
            for spec in all_parameters()}


#: The module's names read from the registry when asked for (module docstring).
LAZY_NAMES: Mapping[str, Callable[[], Any]] = {
    'MODEL_PARAMETERS': model_parameters, 'ALL_PARAMETERS': all_parameters, 'SPECS': specs}


def __getattr__(name: str) -> Any:
    """``MODEL_PARAMETERS``, ``ALL_PARAMETERS``, ``SPECS``: the default machine's."""
    if name in LAZY_NAMES:
        return LAZY_NAMES[name]()
    raise AttributeError(f'module {__name__!r} has no attribute {name!r}')


# Parameters of the twin node platform_sim (docs/twin.md): the plant is load_model of a
# params file and a scene.
SIM_NODE_NAME = 'platform_sim'
SIM_PARAMETERS: tuple[ParamSpec, ...] = (
    ParamSpec('plant.params_file', 'string', '',
              'parameter file of the simulated plant, any machine, read by the rule of '
              'load_model (partial files override the packaged one of their machine); '
              'empty: the --params-file of the command line with a section for the dynamics '
              'node (one file for both nodes), else the default machine\'s packaged '
              'parameters', '',
              max_length=MAX_PATH),
    ParamSpec('plant.scene', 'string', '',
              'scene of the plant, a name from config/scenes or a file (empty: the file\'s '
              'scene parameter, else full); it must compute inertia', '',
              max_length=MAX_PATH),
    ParamSpec('rate', 'double', 1000.0,
              'integration rate of servos and plant: one RK4 step per 1/rate s of '
              'simulated time', 'Hz', minimum=1.0, maximum=100000.0),
    ParamSpec('tick_rate', 'double', 100.0,
              'rate of the node\'s loop: each tick makes the steps due by the steady clock '
              '(sub-stepping at rate) and publishes the state', 'Hz',
              minimum=1.0, maximum=10000.0),
    ParamSpec('max_catch_up', 'double', 0.1,
              'most simulated time one tick may make up after a stall; the rest is dropped '
              '(counted as an overrun: the plant stands still for that time)', 's',
              minimum=0.001, maximum=10.0),
    ParamSpec('servo.bandwidth', 'double', 5.0,
              'bandwidth of the actuator servos: PD gains of a leg of the plant\'s leg-space '
              'mass at the centre with this natural frequency (Servo.for_bandwidth)', 'Hz',
              minimum=0.0, exclusive_minimum=True, maximum=1000.0),
    ParamSpec('servo.damping', 'double', 1.0,
              'damping ratio of the actuator servos', '1', minimum=0.0, maximum=100.0),
    ParamSpec('initial', 'double_array', [],
              'pose at which the platform starts, at rest: one number per coordinate of the '
              'plant, in their order (positions m, angles rad); empty: home', '',
              minimum=-10.0, maximum=10.0),
    ParamSpec('frame_id', 'string', 'simulator_base',
              'header.frame_id of platform_pose, platform_twist and measured_actuator_states: '
              'the setpoints\' frame (REP-103 simulator base, origin at the platform\'s home '
              'position)', '', max_length=MAX_NAME),
    ParamSpec('diagnostics.period', 'double', 1.0,
              'period of the /diagnostics message', 's', minimum=0.01, maximum=3600.0),
)

# Parameters of the motion-cueing node motion_cueing (docs/cueing_node.md), besides the
# cueing group it declares from flight_sim_dynamics.config.cueing.PARAMETER_SPECS.
CUEING_NODE_NAME = 'motion_cueing'
#: the task of its status name in /diagnostics (``<node>: motion cueing``)
CUEING_TASK = 'motion cueing'
CUEING_NODE_PARAMETERS: tuple[ParamSpec, ...] = (
    ParamSpec('params_file', 'string', '',
              "the machine's parameter file, the dynamics node's (it names the machine; its "
              'cueing group gives the defaults of cueing.*); empty: the --params-file of the '
              'command line with a section for the dynamics node, else the default '
              'machine', '', max_length=MAX_PATH),
    ParamSpec('scene', 'string', '',
              'scene the limiter solves the machine with, a name from config/scenes or a '
              "file (empty: the parameter file's, as the dynamics node reads it)", '',
              max_length=MAX_PATH),
    ParamSpec('autostart', 'bool', True,
              'configure and activate at start-up (a bad parameter then ends the process, '
              'exit 2); false: start unconfigured and wait for a lifecycle manager', ''),
    ParamSpec('input.timeout', 'double', 0.2,
              'no vehicle_imu message for this long: the input is stale, the planner\'s '
              'input ramps over this time to the vehicle at rest (its first message) and the '
              'platform washes back to neutral', 's', minimum=0.0, exclusive_minimum=True,
              maximum=3600.0),
    ParamSpec('input.max_specific_force', 'double', 1000.0,
              'vehicle_imu messages with a component of linear_acceleration beyond this are '
              'rejected (out_of_range: no vehicle gives it; the washout would carry it for '
              'ever); a crash of 100 g still passes', 'm/s^2', minimum=0.0,
              exclusive_minimum=True, maximum=1.0e6),
    ParamSpec('input.max_angular_velocity', 'double', 100.0,
              'vehicle_imu messages with a component of angular_velocity beyond this are '
              'rejected (out_of_range)', 'rad/s', minimum=0.0, exclusive_minimum=True,
              maximum=1.0e6),
    ParamSpec('output.frame_id', 'string', 'simulator_base',
              'header.frame_id of the setpoints (the REP-103 simulator base frame, as the '
              "dynamics node's setpoints)", '', max_length=MAX_NAME),
    ParamSpec('diagnostics.period', 'double', 1.0,
              'period of the /diagnostics message', 's', minimum=0.01, maximum=3600.0),
)
