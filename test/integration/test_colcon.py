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
``colcon build`` (colcon from PyPI) produces the layout ``ros2 run`` and the ament index need.

lib/formation_control/<exe>, share/formation_control/{package.xml, config/, launch/, rviz/}, the
index marker; and formation_control_msgs, nested in the repository, built by the same
``colcon build`` when its directory is named as a base path (colcon does not look inside a
package).
"""
import os
from pathlib import Path
import shutil
import subprocess
import sys

import pytest

ROOT = Path(__file__).resolve().parents[2]
MSGS = 'formation_control_msgs'
COLCON = str(Path(sys.executable).parent / 'colcon')
IGNORED = ('.venv', 'build', 'install', 'log', '*.egg-info', '__pycache__', '.git', '*.npz',
           '*.png', '.pytest_cache', '.mypy_cache', '.benchmarks', 'node_modules')


@pytest.fixture
def install(colcon_install):
    return colcon_install


def test_installed_layout(install):
    for exe in ('plant', 'vehicle', 'vehicles', 'monitor', 'recorder', 'formation-control'):
        assert os.access(install / 'lib' / 'formation_control' / exe, os.X_OK), exe
    share = install / 'share' / 'formation_control'
    assert (share / 'package.xml').is_file()
    shipped = sorted(p.name for p in (ROOT / 'config').glob('*.yaml'))
    assert sorted(p.name for p in (share / 'config').glob('*.yaml')) == shipped
    assert sorted(p.name for p in (share / 'launch').iterdir()) == ['fleet.launch.py',
                                                                    'vehicle.launch.py']
    assert (share / 'rviz' / 'formation.rviz').is_file()
    assert (install / 'share' / 'ament_index' / 'resource_index' / 'packages'
            / 'formation_control').is_file()


def test_installed_console_script_finds_configs_through_the_ament_index(install, tmp_path):
    site = next((install / 'lib').glob('python3*/site-packages'))
    env = dict(os.environ, AMENT_PREFIX_PATH=str(install), PYTHONPATH=str(site))
    result = subprocess.run([str(install / 'lib' / 'formation_control' / 'formation-control'),
                             'sim', 'rigid_parallel', '--duration', '1'], cwd=tmp_path, env=env,
                            capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr
    assert 'rigid_parallel: 5 vehicles' in result.stdout
    probe = subprocess.run([sys.executable, '-c', 'import formation_control; '
                            'print(formation_control.__file__)'], env=env, capture_output=True,
                           cwd=tmp_path,
                           text=True, timeout=60)
    assert probe.stdout.startswith(str(site))
    assert list((site / 'formation_control' / 'core').glob('_rk4*.so')), 'the RK4 not built'


def test_colcon_finds_the_nested_interface_package_only_by_its_path(tmp_path):
    def listed(*paths):
        result = subprocess.run([COLCON, 'list', '--names-only', '--base-paths', *map(str, paths)],
                                cwd=tmp_path, capture_output=True, text=True, timeout=60)
        assert result.returncode == 0, result.stderr
        return sorted(result.stdout.split())

    assert listed(ROOT) == ['formation_control']
    assert listed(ROOT, ROOT / MSGS) == ['formation_control', MSGS]


def test_one_colcon_build_installs_both_packages(colcon_workspace):
    install = colcon_workspace / 'install' / MSGS
    if not install.is_dir():
        pytest.skip(f'{MSGS} was not built: cmake or a C++ compiler is missing')
    share = install / 'share' / MSGS
    sources = sorted(p.name for p in (ROOT / MSGS / 'msg').glob('*.msg'))
    assert sorted(p.name for p in (share / 'msg').glob('*.msg')) == sources
    index = install / 'share' / 'ament_index' / 'resource_index'
    assert (index / 'packages' / MSGS).is_file()
    assert sorted((index / 'rosidl_interfaces' / MSGS).read_text().split()) == sorted(
        f'msg/{name}' for stem in sources for name in (stem, stem.replace('.msg', '.idl')))
    site = next((install / 'lib').glob('python3*/site-packages'))
    assert (site / MSGS / 'msg' / '__init__.py').is_file()
    assert (colcon_workspace / 'install' / 'formation_control' / 'share' / 'formation_control'
            / 'package.xml').is_file()


def test_a_plain_colcon_build_without_the_messages_stops_saying_what_to_run(tmp_path):
    """
    The ROS habit: the repository in ``src/``, then ``colcon build``, without the messages.

    On a machine where formation_control_msgs is nowhere (shadowed here by a module that cannot
    be imported), the build of formation_control stops at once and says what to run.
    """
    shutil.copytree(ROOT, tmp_path / 'src' / 'formation_control',
                    ignore=shutil.ignore_patterns(*IGNORED))
    shadow = tmp_path / 'shadow' / MSGS
    shadow.mkdir(parents=True)
    (shadow / '__init__.py').write_text("raise ImportError('not built')\n")
    env = dict(os.environ, PYTHONPATH=str(shadow.parent),
               PATH=f'{Path(sys.executable).parent}{os.pathsep}{os.environ["PATH"]}')
    result = subprocess.run([COLCON, 'build', '--event-handlers', 'console_direct-'],
                            cwd=tmp_path, env=env, capture_output=True, text=True, timeout=600)
    out = result.stdout + result.stderr
    assert result.returncode != 0 and 'Failed   <<< formation_control [' in out, out[-3000:]
    assert ('error: formation_control_msgs is not built and not installed: colcon does not look '
            'inside a package, so name both: colcon build --base-paths src/formation_control '
            'src/formation_control/formation_control_msgs') in out, out[-3000:]
