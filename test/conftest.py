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

import hashlib
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


SERIAL = ('test_secure.py', 'test_signed.py', 'test_flood.py')
"""Files run alone, after the two workers (``make test``): a TLS fleet over Fast DDS 2.14's TCP
transport (plain or signed) missed its 180 s launch deadline twice in five runs beside another
worker's tests, never alone; the flood of malformed samples, whose lockstep fleet shares one
process with the flood's intake, missed its 120 s deadline once in two runs beside the other
worker (2 s of fleet time). (Eight failures of fleets on the other worker, once blamed on the
flood, were a vehicle left running by ``ros2 run`` in a reused domain: see ``rosutil.reap``.)"""


def pytest_collection_modifyitems(items):
    """Mark every test under test/integration ``slow``, those of :data:`SERIAL` ``serial``."""
    for item in items:
        path = Path(item.fspath)
        if INTEGRATION in path.parents:
            item.add_marker(pytest.mark.slow)
        if path.name in SERIAL:
            item.add_marker(pytest.mark.serial)


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


MSGS = 'formation_control_msgs'
MSGS_TOOLS = [tool for tool in ('cmake', os.environ.get('CXX', 'c++'))
              if shutil.which(tool) is None]
"""The tools building formation_control_msgs needs that this machine lacks."""


def colcon_build_command(src, msgs=True):
    """
    Return the one ``colcon build`` of the packages of the repository copied to ``src``.

    formation_control_msgs sits inside the ament_python package, and colcon does not look inside
    a package: both are named by path. Against the ros-jazzy-* wheels (no ROS installation) the
    interface package needs tools/rosidl_wheel_includes.cmake and the venv's interpreter.
    ``msgs=False``: formation_control alone.
    """
    paths = [str(src)] + ([str(src / MSGS)] if msgs else [])
    command = [str(Path(sys.executable).parent / 'colcon'), 'build', '--base-paths', *paths,
               '--event-handlers', 'console_direct-']
    if msgs:
        command += ['--cmake-args', '-DBUILD_TESTING=OFF',
                    f'-DPython3_EXECUTABLE={sys.executable}',
                    f'-DCMAKE_PROJECT_INCLUDE={src / "tools" / "rosidl_wheel_includes.cmake"}']
    return command


COPY_IGNORED = shutil.ignore_patterns(
    '.venv', 'build', 'install', 'log', '*.egg-info', '__pycache__', '.git', '*.npz', '*.png',
    '.pytest_cache', '.mypy_cache', '.benchmarks', 'node_modules')
"""What of the repository is not copied into the workspace: builds, caches (tools' caches
change as the tests run: test_mypy writes .mypy_cache), outputs and third-party bundles."""
FRESH_COLCON = 'FORMATION_CONTROL_TEST_FRESH_COLCON'
"""Set (to anything): build the colcon workspace afresh in the session's temporary directory,
as if no earlier session had built it."""


def _copied_files(root):
    """Yield each file ``shutil.copytree(root, ..., ignore=COPY_IGNORED)`` copies, relative."""
    for here, dirs, files in os.walk(root):
        ignored = COPY_IGNORED(here, dirs + files)
        dirs[:] = sorted(d for d in dirs if d not in ignored)
        for name in sorted(f for f in files if f not in ignored):
            yield Path(here, name).relative_to(root)


def _build_key(command, src):
    """
    Return a digest of everything the workspace's build depends on.

    Each copied file (path, mode, contents), the ``colcon build`` command, the interpreter and
    the venv's set-up stamps (``make setup`` rewrites them when it changes the venv), the tools
    cmake and the compiler.
    """
    digest = hashlib.sha256()
    for rel in _copied_files(ROOT):
        path = ROOT / rel
        digest.update(f'{rel}\0{path.stat().st_mode:o}\0'.encode())
        digest.update(path.read_bytes() if not path.is_symlink() else os.readlink(path).encode())
        digest.update(b'\0')
    digest.update(repr([str(c).replace(str(src), '<src>') for c in command]).encode())
    digest.update(f'{sys.executable}\0{sys.version}\0{sys.prefix}'.encode())
    for stamp in sorted(Path(sys.prefix).glob('.installed*')):
        digest.update(f'{stamp.name}\0{stamp.stat().st_mtime_ns}\0'.encode() + stamp.read_bytes())
    for tool in ('cmake', os.environ.get('CXX', 'c++')):
        found = shutil.which(tool)
        digest.update(f'{tool}\0{found}\0'.encode())
        if found:
            digest.update(str(Path(found).resolve().stat().st_mtime_ns).encode())
    return digest.hexdigest()[:20]


def _build(ws):
    """Copy the repository into ``ws``/src and run the one ``colcon build``; fail with its log."""
    src = ws / 'src' / 'formation_control'
    shutil.copytree(ROOT, src, ignore=COPY_IGNORED)
    command = colcon_build_command(src, msgs=not MSGS_TOOLS)
    env = dict(os.environ, PATH=f'{Path(sys.executable).parent}{os.pathsep}{os.environ["PATH"]}')
    for var in ('AMENT_PREFIX_PATH', 'CMAKE_PREFIX_PATH'):     # the venv holds the ROS wheels
        env[var] = os.pathsep.join(filter(None, [sys.prefix, os.environ.get(var)]))
    result = subprocess.run(command, cwd=ws, env=env, capture_output=True, text=True,
                            timeout=600)
    assert result.returncode == 0, result.stdout + result.stderr


KEPT_BUILDS = 3
"""Workspaces of other sources kept in pytest's cache (the most recently used)."""


@pytest.fixture(scope='session')
def colcon_workspace(tmp_path_factory, pytestconfig):
    """
    Build the repository's packages with one ``colcon build``; return the workspace.

    Both formation_control and formation_control_msgs, unless cmake or a C++ compiler is missing
    (:data:`MSGS_TOOLS`): then formation_control alone.

    The workspace is kept in pytest's cache (.pytest_cache), under a digest of everything the
    build depends on (:func:`_build_key`): the xdist workers and the serial phase of ``make
    test`` share one build of the same sources, and any change to them builds again. A lock
    makes a second process wait for the build under way. The tests only read the workspace.
    Without pytest's cache (``-p no:cacheprovider``) or with :data:`FRESH_COLCON` set, it is
    built afresh in the session's temporary directory.
    """
    cache = getattr(pytestconfig, 'cache', None)
    if cache is None or os.environ.get(FRESH_COLCON):
        ws = tmp_path_factory.mktemp('ws')
        _build(ws)
        return ws
    import fcntl
    base = cache.mkdir('colcon_workspace')
    src = Path('/') / 'src' / 'formation_control'         # stands for ws/src/formation_control
    key = _build_key(colcon_build_command(src, msgs=not MSGS_TOOLS), src)
    ws, done = base / key, base / key / 'built'
    with open(base / 'lock', 'w') as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if not done.exists():
            shutil.rmtree(ws, ignore_errors=True)       # a build that failed or was cut short
            ws.mkdir()
            _build(ws)
            done.write_text(key)
        os.utime(done)
        older = sorted((p for p in base.iterdir() if (p / 'built').exists() and p != ws),
                       key=lambda p: (p / 'built').stat().st_mtime, reverse=True)
        for stale in older[KEPT_BUILDS - 1:]:
            shutil.rmtree(stale, ignore_errors=True)
    return ws


@pytest.fixture(scope='session')
def colcon_install(colcon_workspace):
    """Return install/formation_control of the colcon workspace."""
    return colcon_workspace / 'install' / 'formation_control'
