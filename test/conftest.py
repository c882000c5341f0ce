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

import os
from pathlib import Path
import shutil
import subprocess
import sys
from types import SimpleNamespace

import pytest

ROOT = Path(__file__).resolve().parents[1]
CONFIG = ROOT / 'config'


@pytest.fixture
def config_dir():
    return CONFIG


os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
INTEGRATION = Path(__file__).resolve().parent / 'integration'


def pytest_collection_modifyitems(items):
    """Mark every test under test/integration ``slow`` (``make test-fast`` leaves them out)."""
    for item in items:
        if INTEGRATION in Path(item.fspath).parents:
            item.add_marker(pytest.mark.slow)


@pytest.fixture
def ros(monkeypatch):
    """Give the test a private ROS_DOMAIN_ID, the processes it starts and a probe node."""
    from rosutil import domains, Probe, Processes, ros_environment, shm_clean
    with domains() as (did,):
        env = ros_environment(did)
        monkeypatch.setenv('ROS_DOMAIN_ID', str(did))
        procs = Processes(env)
        probe = Probe(did)
        try:
            yield SimpleNamespace(domain_id=did, env=env, procs=procs, probe=probe)
        finally:
            probe.close()
            procs.stop_all()
            shm_clean(env)


@pytest.fixture
def nodes():
    """
    Give the test in-process nodes on a private ROS_DOMAIN_ID.

    ``nodes.plant(...)``, ``nodes.vehicle(k, ...)``, ``nodes.monitor(...)``, with the probe's
    ``collect`` and ``spin_until``; every node is destroyed and the context shut down at
    teardown.
    """
    from rosutil import domains, Nodes
    with domains() as (did,):
        made = Nodes(did)
        try:
            yield made
        finally:
            made.close()


@pytest.fixture(scope='session')
def colcon_install(tmp_path_factory):
    """Build the package with ``colcon build`` once; return install/formation_control."""
    ws = tmp_path_factory.mktemp('ws')
    shutil.copytree(ROOT, ws / 'src' / 'formation_control', ignore=shutil.ignore_patterns(
        '.venv', 'build', 'install', 'log', '*.egg-info', '__pycache__', '.git', '*.npz',
        '*.png', '.pytest_cache'))
    result = subprocess.run([str(Path(sys.executable).parent / 'colcon'), 'build',
                             '--event-handlers', 'console_direct-'],
                            cwd=ws, capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stdout + result.stderr
    return ws / 'install' / 'formation_control'
