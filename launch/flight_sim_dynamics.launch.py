r"""Launch the flight_sim_dynamics node (a managed node), optionally the planner.

For a ROS 2 install (``ros2 launch`` is not on PyPI):

    ros2 launch flight_sim_dynamics flight_sim_dynamics.launch.py
    ros2 launch flight_sim_dynamics flight_sim_dynamics.launch.py \\
        namespace:=sim scene:=quasi_static params_file:=/path/to/params.yaml
    ros2 launch flight_sim_dynamics flight_sim_dynamics.launch.py \\
        autostart:=false        # then: ros2 lifecycle set /flight_sim_dynamics configure
    ros2 launch flight_sim_dynamics flight_sim_dynamics.launch.py planner:=true
"""
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, OpaqueFunction
from launch.conditions import IfCondition
from launch.substitutions import LaunchConfiguration, PathJoinSubstitution
from launch_ros.actions import LifecycleNode, Node
from launch_ros.substitutions import FindPackageShare

PACKAGE = 'flight_sim_dynamics'


def _node(context, *args, **kwargs):
    """The node; ``scene`` overrides the params file only when given."""
    overrides = {'autostart': LaunchConfiguration('autostart').perform(context).lower()
                 in ('true', '1')}
    scene = LaunchConfiguration('scene').perform(context)
    if scene:
        overrides['scene'] = scene
    return [LifecycleNode(
        package=PACKAGE, executable='dynamics_node', name=PACKAGE,
        namespace=LaunchConfiguration('namespace'),
        parameters=[LaunchConfiguration('params_file'), overrides],
        output='screen')]


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
        DeclareLaunchArgument('planner', default_value='false',
                              description='also run the demo planner (looping the paper\'s '
                                          'motions)'),
        OpaqueFunction(function=_node),
        Node(package=PACKAGE, executable='flight-sim-dynamics', name='demo_planner',
             arguments=['demo-planner', '--loop'], namespace=LaunchConfiguration('namespace'),
             output='screen', condition=IfCondition(LaunchConfiguration('planner'))),
    ])
