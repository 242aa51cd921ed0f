r"""Launch the flight_sim_dynamics node (a managed node), optionally the demo
planner, the motion-cueing node (motion_cueing: vehicle_imu in, the node's
setpoints out) and the twin (platform_sim, fed by the node's actuator_states),
on either machine: ``machine:=stewart_6dof`` takes the packaged hexapod file,
``params_file:=...`` a file of one's own (it names its machine); neither: the
3-DOF machine. The twin simulates the node's machine (the same file as its
``plant.params_file``), the cueing node drives it (the same file as its
``params_file``: the machine and its ``cueing`` group), the planner plays that
machine's motions (the planner and the cueing node both publish setpoints: one
at a time). The node gets its file as ``--params-file FILE`` would hand it
over: a file of one's own for a node in a namespace has a section that reaches
it (``/**/flight_sim_dynamics``, ``/<namespace>/flight_sim_dynamics`` or ``/**``).

For a ROS 2 install (``ros2 launch`` is not on PyPI):

    ros2 launch flight_sim_dynamics flight_sim_dynamics.launch.py
    ros2 launch flight_sim_dynamics flight_sim_dynamics.launch.py machine:=stewart_6dof \\
        planner:=true twin:=true
    ros2 launch flight_sim_dynamics flight_sim_dynamics.launch.py \\
        namespace:=sim scene:=quasi_static params_file:=/path/to/params.yaml
    ros2 launch flight_sim_dynamics flight_sim_dynamics.launch.py \\
        autostart:=false        # then: ros2 lifecycle set /flight_sim_dynamics configure
    ros2 launch flight_sim_dynamics flight_sim_dynamics.launch.py planner:=true twin:=true
    ros2 launch flight_sim_dynamics flight_sim_dynamics.launch.py machine:=stewart_6dof \
        cueing:=true twin:=true        # then publish sensor_msgs/Imu on vehicle_imu
    ros2 launch flight_sim_dynamics flight_sim_dynamics.launch.py use_sim_time:=true
"""
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, OpaqueFunction
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import LifecycleNode, Node

from flight_sim_dynamics.config.machine_files import launch_params_file

PACKAGE = 'flight_sim_dynamics'


def _nodes(context, *args, **kwargs):
    """The node (and the twin, the planner) on the chosen file; ``scene``
    overrides the params file only when given. The node gets the file as
    ``--params-file`` (a path in ``parameters``), its sections applying as rcl
    applies them: the packaged files' ``/**/flight_sim_dynamics`` in any namespace.
    """
    def value(name):
        return LaunchConfiguration(name).perform(context)

    def flag(name):
        return value(name).lower() in ('true', '1')
    params_file = str(launch_params_file(value('machine'), value('params_file')))
    namespace = LaunchConfiguration('namespace')
    overrides = {'autostart': flag('autostart'), 'use_sim_time': flag('use_sim_time')}
    if value('scene'):
        overrides['scene'] = value('scene')
    nodes = [LifecycleNode(
        package=PACKAGE, executable='dynamics_node', name=PACKAGE, namespace=namespace,
        parameters=[params_file, overrides], output='screen')]
    if flag('twin'):
        nodes.append(Node(package=PACKAGE, executable='platform_sim', name='platform_sim',
                          namespace=namespace,
                          parameters=[{'use_sim_time': overrides['use_sim_time'],
                                       'plant.params_file': params_file}],
                          remappings=[('actuator_commands', 'actuator_states')],
                          output='screen'))
    if flag('cueing'):
        cueing = {'params_file': params_file, 'autostart': overrides['autostart'],
                  'use_sim_time': overrides['use_sim_time']}
        if value('scene'):
            cueing['scene'] = value('scene')
        nodes.append(LifecycleNode(package=PACKAGE, executable='motion_cueing',
                                   name='motion_cueing', namespace=namespace,
                                   parameters=[cueing], output='screen'))
    if flag('planner'):
        nodes.append(Node(package=PACKAGE, executable='flight-sim-dynamics', name='demo_planner',
                          arguments=['demo-planner', '--params', params_file, '--example', 'all',
                                     '--loop'],
                          namespace=namespace, output='screen'))
    return nodes


def generate_launch_description() -> LaunchDescription:
    return LaunchDescription([
        DeclareLaunchArgument(
            'machine', default_value='',
            description='packaged machine: its file config/<machine>.yaml of the installed '
                        'share directory (stewart_6dof, stewart_tsai2000; empty: the 3-DOF '
                        'machine, unless params_file is given)'),
        DeclareLaunchArgument(
            'params_file', default_value='',
            description='parameter file of the node (it names its machine; empty: the '
                        'packaged file of machine)'),
        DeclareLaunchArgument('namespace', default_value='',
                              description='namespace of the node (and the planner)'),
        DeclareLaunchArgument('scene', default_value='',
                              description='scene name or file (default: the params file\'s)'),
        DeclareLaunchArgument('autostart', default_value='true',
                              description='configure and activate at once (false: wait for '
                                          'a lifecycle manager or ros2 lifecycle set)'),
        DeclareLaunchArgument('use_sim_time', default_value='false',
                              description='the node\'s clock from /clock'),
        DeclareLaunchArgument('planner', default_value='false',
                              description='also run the demo planner (looping the machine\'s '
                                          'planner motions: on the 3-DOF machine the paper\'s '
                                          'three motions and a motion-cueing sequence)'),
        DeclareLaunchArgument('cueing', default_value='false',
                              description='also run the motion-cueing node (motion_cueing) on '
                                          'the node\'s file: sensor_msgs/Imu on vehicle_imu in, '
                                          'the node\'s setpoints out'),
        DeclareLaunchArgument('twin', default_value='false',
                              description='also run the twin (platform_sim) on the node\'s '
                                          'actuator_states, simulating the node\'s machine'),
        OpaqueFunction(function=_nodes),
    ])
