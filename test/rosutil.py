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

"""Test harness for ROS 2 nodes: a private domain, processes, in-process nodes, probes."""
import contextlib
from importlib.metadata import entry_points
import itertools
import math
import os
from pathlib import Path
import subprocess
import sys
import tempfile
import time

from formation_control.protocol.messages import METRIC_DOC
from formation_control.swarm import stop
from rcl_interfaces.msg import Log
import rclpy
from rclpy.executors import SingleThreadedExecutor
from rclpy.experimental import EventsExecutor
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

BIN = Path(sys.executable).parent
CONFIG = Path(__file__).resolve().parents[1] / 'config'


STOP_GRACE = (12.0, 5.0)
"""A test's SIGINT deadlines: longer than a swarm's own (5 + 3 s) to stop its fleet."""


class Processes:
    """Processes a test starts; all of them are stopped (INT, INT, KILL) at teardown."""

    def __init__(self, env):
        self.env = env
        self.procs = []

    def start(self, exe, *args):
        log = tempfile.TemporaryFile('w+')
        proc = subprocess.Popen([str(BIN / exe), *map(str, args)], env=self.env, stdout=log,
                                stderr=subprocess.STDOUT, text=True, stdin=subprocess.DEVNULL)
        proc.log = log
        self.procs.append(proc)
        return proc

    def run(self, exe, *args, timeout=60):
        """Run to the end; past ``timeout``, stop it with INT first (a swarm stops its fleet)."""
        proc = subprocess.Popen([str(BIN / exe), *map(str, args)], env=self.env, text=True,
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                stdin=subprocess.DEVNULL)
        try:
            out, err = proc.communicate(timeout=timeout)
        except subprocess.TimeoutExpired:
            stop([proc], grace=STOP_GRACE)
            proc.communicate()
            raise
        return subprocess.CompletedProcess(proc.args, proc.returncode, out, err)

    def stop_all(self):
        codes = stop(self.procs, grace=STOP_GRACE)
        for proc in self.procs:
            proc.log.close()
        return codes


def metric_values(msg):
    """Return {metric: value} of a FormationMetrics message, those that apply (not NaN)."""
    values = {name: getattr(msg, name) for name in METRIC_DOC}
    return {name: v for name, v in values.items() if not math.isnan(v)}


def output(proc):
    proc.log.seek(0)
    return proc.log.read()


def interrupt(proc, timeout=10.0):
    """SIGINT once and return the exit code (None if it did not stop in time)."""
    proc.send_signal(2)
    try:
        return proc.wait(timeout=timeout)
    except subprocess.TimeoutExpired:
        return None


class Probe:
    """An in-process node on its own context in the test's domain."""

    def __init__(self, domain_id, name='probe', executor=SingleThreadedExecutor):
        self.context = rclpy.Context()
        rclpy.init(context=self.context, domain_id=domain_id,
                   signal_handler_options=rclpy.SignalHandlerOptions.NO)
        self.node = rclpy.create_node(name, context=self.context)
        self.executor = executor(context=self.context)
        self.executor.add_node(self.node)

    def spin_until(self, predicate, timeout=20.0):
        end = time.monotonic() + timeout
        while not predicate():
            if time.monotonic() > end:
                return False
            self.executor.spin_once(timeout_sec=0.05)
        return True

    def spin_for(self, seconds):
        """
        Spin for ``seconds``.

        Only where the property is a span of time (a silence longer than a timeout), never to
        wait for something to happen (``spin_until`` that).
        """
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            self.executor.spin_once(timeout_sec=min(0.05, max(0.0, end - time.monotonic())))

    def collect(self, msg_type, topic, qos):
        box = []
        self.node.create_subscription(msg_type, topic, box.append, qos)
        return box

    def close(self):
        self.executor.shutdown()
        self.node.destroy_node()
        self.context.try_shutdown()


def node_args(path=None, *params):
    """Return a node's ``--ros-args``: a parameter file and ``-p`` overrides, as given to it."""
    out = ['--ros-args']
    if path is not None:
        out += ['--params-file', str(path)]
    for p in params:
        out += ['-p', p]
    return out


ROSOUT_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1000,
                        reliability=ReliabilityPolicy.RELIABLE,
                        durability=DurabilityPolicy.TRANSIENT_LOCAL)


class Nodes(Probe):
    """
    The package's nodes built in this process, on the probe's context.

    One DDS participant (no discovery between processes to wait for), one events executor, as
    ``runner`` spins the nodes of an executable. Their log lines are collected from ``/rosout``.
    """

    def __init__(self, domain_id):
        super().__init__(domain_id, executor=EventsExecutor)
        self.nodes = []
        self.silent = []
        self.rosout = self.collect(Log, '/rosout', ROSOUT_QOS)

    def add(self, node):
        for old in [n for n in self.silent if n.get_name() == node.get_name()]:
            self.silent.remove(old)
            old.destroy_node()
        self.executor.add_node(node)
        self.nodes.append(node)
        return node

    def plant(self, path, *params):
        from formation_control.ros.plant import PlantNode
        return self.add(PlantNode(context=self.context, cli_args=node_args(path, *params)))

    def vehicle(self, k, path, *params):
        from formation_control.ros.vehicle import VehicleNode
        return self.add(VehicleNode(k, context=self.context,
                                    cli_args=node_args(path, f'vehicle_id:={k}', *params)))

    def lockstep_run(self, cfg, record, *params, timeout=120):
        """
        Run the plant and every vehicle of scenario ``cfg`` to the end; return the record.

        The plant writes its record to ``record``; every node takes the ``-p`` ``params``.
        """
        from formation_control.sim import simulator
        plant = self.plant(cfg, *params, f'record_path:={record}')
        for k in range(1, plant.sc.num_vehicles + 1):
            self.vehicle(k, cfg, *params)
        assert self.spin_until(lambda: plant.done, timeout=timeout)
        return simulator.load_run(record)

    def monitor(self, *params):
        from formation_control.ros.monitor import MonitorNode
        return self.add(MonitorNode(context=self.context, cli_args=node_args(None, *params)))

    def remove(self, node):
        """
        Silence ``node``: out of the executor, it hears and says nothing more.

        As a process that stopped. It is destroyed when a node of the same name is added (the
        events executor may still hold events of the node just removed: destroyed now, their
        callbacks would fail) or at teardown.
        """
        self.executor.remove_node(node)
        self.nodes.remove(node)
        self.silent.append(node)

    def logged(self, node, text):
        """Whether ``node`` has logged a line containing ``text``."""
        name = node if isinstance(node, str) else node.get_name()
        return any(m.name == name and text in m.msg for m in self.rosout)

    def close(self):
        for node in reversed(self.nodes):
            self.executor.remove_node(node)
        self.executor.shutdown()
        for node in self.nodes + self.silent:
            node.destroy_node()
        self.nodes, self.silent = [], []
        super().close()


def ament_prefix(root):
    """Return an ament prefix where launch_ros finds this package's nodes (the venv's scripts)."""
    index = root / 'share' / 'ament_index' / 'resource_index' / 'packages'
    index.mkdir(parents=True)
    (index / 'formation_control').touch()
    lib = root / 'lib' / 'formation_control'
    lib.mkdir(parents=True)
    for script in entry_points(group='console_scripts'):
        if script.value.startswith('formation_control.ros.'):
            (lib / script.name).symlink_to(BIN / script.name)
    return root


def shm_clean(env):
    fastdds = BIN / 'fastdds'
    if fastdds.exists():
        subprocess.run([str(fastdds), 'shm', 'clean'], env=env, capture_output=True, timeout=30)


def ros_environment(domain_id):
    env = dict(os.environ, ROS_DOMAIN_ID=str(domain_id), ROS_AUTOMATIC_DISCOVERY_RANGE='LOCALHOST',
               PYTHONUNBUFFERED='1')
    env.pop('RMW_IMPLEMENTATION', None)
    return env


@contextlib.contextmanager
def domains(count=1):
    """
    Reserve ``count`` ROS_DOMAIN_IDs for the block; at its end, no process it started runs on.

    Every process started in the block inherits :data:`MARK_ENV`; at the end :func:`reap` waits
    for them, kills those left and the block fails naming them. domain_coordinator's own
    context swallows an OSError (TimeoutError, FileNotFoundError ...) raised in its block; it
    is carried past.
    """
    from domain_coordinator import domain_id
    error = None
    with contextlib.ExitStack() as stack:
        ids = [stack.enter_context(domain_id()) for _ in range(count)]
        mark = f'{os.getpid()}-{next(_MARKS)}-{"-".join(map(str, ids))}'
        outer = os.environ.get(MARK_ENV)
        os.environ[MARK_ENV] = mark
        try:
            yield ids
        except OSError as err:
            error = err
        finally:
            _restore(MARK_ENV, outer)
            strays = reap(mark)
    if error is not None:
        raise error
    assert not strays, f'processes outlived their test on its domains {ids}: {strays}'


MARK_ENV = 'FORMATION_CONTROL_TEST_DOMAINS'
"""Set while a test holds its domains: every process it starts inherits it, and only those."""
_MARKS = itertools.count()


def _restore(name, value):
    if value is None:
        os.environ.pop(name, None)
    else:
        os.environ[name] = value


STRAY_DEADLINE = 15.0
"""Seconds a test's processes have to end by themselves after its teardown (GRACE + 5 s)."""


def _marked(mark):
    """Return {pid: command line} of the other processes whose environment holds ``mark``."""
    wanted = f'{MARK_ENV}={mark}'.encode()
    found = {}
    for proc in Path('/proc').iterdir():
        if not proc.name.isdigit() or int(proc.name) == os.getpid():
            continue
        try:
            if wanted in (proc / 'environ').read_bytes().split(b'\0'):
                found[int(proc.name)] = (proc / 'cmdline').read_bytes().replace(b'\0', b' ')
        except OSError:
            pass
    return found


def reap(mark, deadline=STRAY_DEADLINE):
    """
    Wait for every process a test started (``mark``) to end; kill those left; return them.

    A process the test started, or a child of one, left running in the test's domain would
    talk into the next test given that domain.
    """
    end = time.monotonic() + deadline
    while (left := _marked(mark)) and time.monotonic() < end:
        time.sleep(0.2)
    for pid in left:
        with contextlib.suppress(OSError):
            os.kill(pid, 9)
    return {pid: cmd.decode(errors='replace')[-200:] for pid, cmd in left.items()}
