"""The schema: the one declaration of every parameter (name, kind, default,
unit, physical bounds, meaning), for the solver and the node alike.

Model parameters are the paper's application data (Section 3; geometry of
eq. 7-8, mass properties of eq. 18-19, gravity); node parameters tune the
ROS 2 node. Every number is bounded to a physical or sensible range (a
centre of mass at 1e300 m is not a mechanism), every string in length. Bodies
and geometry keys: :data:`machines.staicu.model.BODY_NAMES`,
:data:`machines.staicu.model.GEOMETRY_KEYS`.
"""
from __future__ import annotations

from typing import Any, Mapping

from ..core.parameter_spec import MAX_COM, MAX_INERTIA, MAX_LENGTH, MAX_MASS, ParamSpec
from ..machines.staicu.model import BODY_NAMES, GEOMETRY_KEYS

# Physical bounds shared by every body (and the payload): MAX_MASS, MAX_COM,
# MAX_INERTIA, MAX_LENGTH are every machine's (core/parameter_spec.py).
MAX_NAME = 256              # characters of a frame id
MAX_PATH = 4096             # characters of a file path (PATH_MAX on Linux)


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


MODEL_PARAMETERS: tuple[ParamSpec, ...] = tuple(_model_specs())

# Node parameters: declared by the node, also accepted by load_model (one file serves both).
# (QoS: rclpy's read-only qos_overrides.<topic>.* parameters, declared by the node's endpoints.)
NODE_PARAMETERS: tuple[ParamSpec, ...] = (
    ParamSpec('limits.warn_fraction', 'double', 0.9,
              "status WARN when a limit of the machine (a stroke, speed, force, a hexapod's "
              'joint angle) is used to at least this fraction (stroke: of the half-range '
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
              'a position the machine does not follow (the 3-DOF machine\'s sway: position.y, '
              'and linear.y of twist and acceleration per s, s^2) beyond this is reported as '
              'motion the machine cannot follow, then ignored', 'm',
              minimum=0.0, maximum=10.0),
    ParamSpec('input.angle_tolerance', 'double', 1.0e-3,
              'an angle the machine does not follow (the 3-DOF machine\'s yaw, and a pitch '
              'other than zero or its parasitic pitch) beyond this is reported as motion the '
              'machine cannot follow, then ignored', 'rad',
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

ALL_PARAMETERS: tuple[ParamSpec, ...] = MODEL_PARAMETERS + NODE_PARAMETERS
SPECS: Mapping[str, ParamSpec] = {spec.name: spec for spec in ALL_PARAMETERS}


def defaults() -> dict[str, Any]:
    """The packaged default value of every parameter, by dotted name."""
    return {spec.name: (list(spec.default) if isinstance(spec.default, list) else spec.default)
            for spec in ALL_PARAMETERS}


if set(_GEOMETRY_DEFAULTS) != set(GEOMETRY_KEYS):   # one list of lengths: the model's
    raise ImportError(f'schema geometry {sorted(_GEOMETRY_DEFAULTS)} != staicu.model.GEOMETRY_KEYS')

# Parameters of the twin node platform_sim (docs/twin.md): the plant is load_model of a
# params file and a scene.
SIM_NODE_NAME = 'platform_sim'
SIM_PARAMETERS: tuple[ParamSpec, ...] = (
    ParamSpec('plant.params_file', 'string', '',
              'parameter file of the simulated plant, either machine, read by the rule of '
              'load_model (partial files override the packaged one of their machine); '
              'empty: the --params-file of the command line with a section for the dynamics '
              'node (one file for both nodes), else the packaged 3-DOF parameters', '',
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
              'plant (surge m, heave m, roll rad; a hexapod: surge, sway, heave m, roll, '
              'pitch, yaw rad); empty: home', '', minimum=-10.0, maximum=10.0),
    ParamSpec('frame_id', 'string', 'simulator_base',
              'header.frame_id of platform_pose, platform_twist and measured_actuator_states: '
              'the setpoints\' frame (REP-103 simulator base, origin at the platform\'s home '
              'position: G\'s central position on the 3-DOF machine)', '', max_length=MAX_NAME),
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
              'command line with a section for the dynamics node, else the packaged 3-DOF '
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
