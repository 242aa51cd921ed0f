r"""Launch the flight_sim_dynamics node (a managed node), optionally the demo
planner and the twin (platform_sim, fed by the node's actuator_states).

For a ROS 2 install (``ros2 launch`` is not on PyPI):

    ros2 launch flight_sim_dynamics flight_sim_dynamics.launch.py
    ros2 launch flight_sim_dynamics flight_sim_dynamics.launch.py \\
        namespace:=sim scene:=quasi_static params_file:=/path/to/params.yaml
    ros2 launch flight_sim_dynamics flight_sim_dynamics.launch.py \\
        autostart:=false        # then: ros2 lifecycle set /flight_sim_dynamics configure
    ros2 launch flight_sim_dynamics flight_sim_dynamics.launch.py planner:=true twin:=true
    ros2 launch flight_sim_dynamics flight_sim_dynamics.launch.py use_sim_time:=true
"""
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, OpaqueFunction
from launch.conditions import IfCondition
from launch.substitutions import LaunchConfiguration, PathJoinSubstitution
from launch_ros.actions import LifecycleNode, Node
from launch_ros.substitutions import FindPackageShare

PACKAGE = 'flight_sim_dynamics'


def _node(context, *args, **kwargs):
    """The node (and the twin); ``scene`` overrides the params file only when given."""
    def flag(name):
        return LaunchConfiguration(name).perform(context).lower() in ('true', '1')
    overrides = {'autostart': flag('autostart'), 'use_sim_time': flag('use_sim_time')}
    scene = LaunchConfiguration('scene').perform(context)
    if scene:
        overrides['scene'] = scene
    nodes = [LifecycleNode(
        package=PACKAGE, executable='dynamics_node', name=PACKAGE,
        namespace=LaunchConfiguration('namespace'),
        parameters=[LaunchConfiguration('params_file'), overrides],
        output='screen')]
    if flag('twin'):
        nodes.append(Node(package=PACKAGE, executable='platform_sim', name='platform_sim',
                          namespace=LaunchConfiguration('namespace'),
                          parameters=[{'use_sim_time': overrides['use_sim_time']}],
                          remappings=[('actuator_commands', 'actuator_states')],
                          output='screen'))
    return nodes


def generate_launch_description() -> LaunchDescription:
    return LaunchDescription([
        DeclareLaunchArgument(
            'params_file', description='parameter file of the node',
            default_value=PathJoinSubstitution([FindPackageShare(PACKAGE), 'config',
                                                'flight_sim_dynamics.yaml'])),
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
                              description='also run the demo planner (looping the paper\'s '
                                          'three motions and a motion-cueing sequence)'),
        DeclareLaunchArgument('twin', default_value='false',
                              description='also run the twin (platform_sim) on the node\'s '
                                          'actuator_states'),
        OpaqueFunction(function=_node),
        Node(package=PACKAGE, executable='flight-sim-dynamics', name='demo_planner',
             arguments=['demo-planner', '--example', 'all', '--loop'],
             namespace=LaunchConfiguration('namespace'),
             output='screen', condition=IfCondition(LaunchConfiguration('planner'))),
    ])
