"""Build script of the flight_sim_dynamics ament_python package: colcon build
(scripts in lib/flight_sim_dynamics, setup.cfg) or pip install (scripts in
<venv>/bin); data files in <prefix>/share/flight_sim_dynamics.
"""
from glob import glob

from setuptools import Extension, find_packages, setup

package_name = 'flight_sim_dynamics'

# The compiled kernel (docs/kernel.md); optional: without a C compiler the Python code
# solves (same results, slower). -ffp-contract=off: no fused multiply-add, as in Python.
KERNEL_FLAGS = ['-O2', '-ffp-contract=off', '-fno-math-errno']
# one per machine, in the machine's own folder: machines/<name>/kernel.c -> machines.<name>._kernel
# (what the kernels share: core/kernel_support.h, core/kernel_bindings.h)
kernels = [Extension(f"{package_name}.machines.{source.split('/')[-2]}._kernel", sources=[source],
                     include_dirs=[f'{package_name}/core'],
                     depends=sorted(glob(f'{package_name}/core/kernel_*.h')),
                     optional=True, extra_compile_args=KERNEL_FLAGS)
           for source in sorted(glob(f'{package_name}/machines/*/kernel.c'))]

setup(
    name=package_name,
    version='0.1.0',
    packages=find_packages(exclude=['test', 'test.*', 'benchmarks', 'benchmarks.*',
                                    'scripts', 'scripts.*']),
    ext_modules=kernels,
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + package_name]),
        ('share/' + package_name, ['package.xml']),
        ('share/' + package_name + '/config', sorted(glob('config/*.yaml'))),
        ('share/' + package_name + '/config/scenes', sorted(glob('config/scenes/*.yaml'))),
        ('share/' + package_name + '/launch', sorted(glob('launch/*.launch.py'))),
    ],
    python_requires='>=3.10',
    # matplotlib is optional: only plot, animate, bench, workspace and the demo draw figures
    # (pip install '.[plot]'); the library and the node never import it.
    install_requires=['setuptools', 'numpy', 'PyYAML', 'scipy'],
    extras_require={'plot': ['matplotlib'],
                    'test': ['pytest', 'hypothesis', 'matplotlib']},
    zip_safe=False,
    maintainer='flight_sim_dynamics maintainers',
    maintainer_email='flight_sim_dynamics@example.com',
    description='Inverse dynamics of motion simulators: a 3-DOF parallel flight simulator '
                'and 6-DOF Stewart-Gough hexapods (library, CLI, ROS 2 node, twin).',
    license='Apache-2.0',
    entry_points={
        'console_scripts': [
            'flight-sim-dynamics = flight_sim_dynamics.__main__:main',
            'dynamics_node = flight_sim_dynamics.ros.node:main',
            'platform_sim = flight_sim_dynamics.ros.sim_node:main',
            'motion_cueing = flight_sim_dynamics.ros.motion_cueing:main',
        ],
        # the registry of machines (flight_sim_dynamics/machines/__init__.py): each
        # machine by its name (Machine.name); another distribution adds its own here
        'flight_sim_dynamics.machines': [
            'flight_simulator_3dof = flight_sim_dynamics.machines.staicu.machine:MACHINE',
            'stewart = flight_sim_dynamics.machines.stewart.machine:MACHINE',
        ],
    },
)
