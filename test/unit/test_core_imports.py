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

"""
The pure floors (core, sim, protocol) load nothing from ROS.

Importing it and running a simulation in a fresh interpreter loads no ROS module, even though
rclpy and ament_index_python are installed alongside.
"""
import importlib.util
import json
from pathlib import Path
import subprocess
import sys
import textwrap

import pytest

ROS_PREFIXES = ('rclpy', 'rcl', 'rmw', 'geometry_msgs', 'nav_msgs', 'std_msgs',
                'builtin_interfaces', 'ament_index_python')
PACKAGE = Path(__file__).resolve().parents[2] / 'formation_control'
PURE_MODULES = tuple(f'formation_control.{floor}.{path.stem}'
                     for floor in ('core', 'sim', 'protocol')
                     for path in sorted((PACKAGE / floor).glob('[a-z]*.py')))

REPORT = textwrap.dedent(f"""
    import json
    import sys
    ros = sorted(m for m in sys.modules if m.startswith({ROS_PREFIXES!r}))
    print(json.dumps({{'ros': ros, 'modules': sorted(sys.modules)}}))
""")

CORE_RUN = '\n'.join(f'import {name}' for name in PURE_MODULES) + """
from formation_control.core.scenario import resolve
from formation_control.sim.simulator import simulate, summary
for params in ({'num_vehicles': 3, 'duration': 0.2},
               {'num_vehicles': 2, 'model': 'rigid_couple', 'formation': 'circular',
                'controller': 'pi', 'flow': [0.3, 0.0], 'duration': 0.2}):
    run = simulate(resolve(params))
    assert run.X.shape == (3, 6, params['num_vehicles'])
    summary(run)
"""


def _child(code):
    proc = subprocess.run([sys.executable, '-c', code + REPORT], capture_output=True, text=True,
                          timeout=60)
    assert proc.returncode == 0, proc.stderr
    return json.loads(proc.stdout.splitlines()[-1])


def test_core_and_simulation_load_no_ros_module():
    report = _child(CORE_RUN)
    assert report['ros'] == []
    loaded = set(report['modules'])
    assert set(PURE_MODULES) <= loaded and len(PURE_MODULES) >= 25
    assert 'numpy' in loaded
    assert 'formation_control.cli' not in loaded


@pytest.mark.parametrize('module', ['ament_index_python', 'rclpy'])
def test_the_check_sees_ros_modules(module):
    if importlib.util.find_spec(module) is None:
        pytest.skip(f'{module} is not installed')
    assert module in _child(f'import {module}\n')['ros']


def test_only_the_bag_code_needs_rosbags(tmp_path):
    pytest.importorskip('rclpy', reason='the nodes need rclpy')
    """The nodes and ``formation-control report x.npz`` run with rosbags uninstalled."""
    code = f"""
import sys
sys.modules['rosbags'] = None                      # as if it were not installed
import formation_control.ros.plant, formation_control.ros.vehicle, formation_control.ros.monitor
from formation_control import cli
from formation_control.core import scenario
from formation_control.sim import simulator
sc = scenario.resolve({{'num_vehicles': 2, 'duration': 0.2}})
simulator.simulate(sc).save({str(tmp_path / 'run.npz')!r})
sys.argv = ['formation-control', 'report', {str(tmp_path / 'run.npz')!r}]
assert cli.main() == 0
"""
    proc = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True,
                          timeout=60)
    assert proc.returncode == 0, proc.stderr
    assert 'converged' in proc.stdout
