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
``formation-control swarm``: a fleet as real processes, optionally recorded to a bag.

The processes are the plant, one ``vehicle`` process per vehicle and the ``monitor`` (the
executables ``ros2 run`` starts).
"""
import os
from pathlib import Path
import shutil
import signal
import subprocess
import sys
import tempfile
import time

from formation_control.core import simulator
import yaml

RECORDED_DEPTH = 500
"""With a bag: the history of the odometry, state and command writers (samples; 10 s at
50 Hz). DDS matches a writer to the recorder's reader on each side in its own time; a writer
that matches after the first steps resends its transient-local history, which must still
hold step 0."""


def namespace_prefix(namespace):
    """Return the topic prefix of a fleet's namespace: '/' or '/fleet_a/'."""
    return '/' + ''.join(f'{part}/' for part in namespace.split('/') if part)


def write_params(sc, path, recorded=False, namespace='/'):
    """
    Write the resolved scenario as a ROS 2 parameter file at ``path``; return the path.

    Empty lists are left out: ROS types them. ``recorded``: the state writers keep
    :data:`RECORDED_DEPTH` samples (``qos_overrides`` of the topics in ``namespace``), so the
    bag misses no step.
    """
    values = {k: v for k, v in sc.to_dict().items() if v != []}
    prefix = namespace_prefix(namespace)
    if recorded:
        values['qos_overrides'] = {
            f'{prefix}vehicle_{k}/{name}': {'publisher': {'depth': RECORDED_DEPTH}}
            for k in range(1, sc.num_vehicles + 1) for name in ('odom', 'formation_state', 'cmd')}
    Path(path).write_text(yaml.safe_dump({'/**': {'ros__parameters': values}}))
    return str(path)


def executable(name):
    """
    Return the path of the console script ``name``.

    It is looked for beside the running one (colcon lib/), beside the interpreter (venv), then
    on PATH.
    """
    near = [Path(sys.argv[0]).resolve().parent / name, Path(sys.executable).parent / name]
    found = next((str(p) for p in near if p.exists()), None) or shutil.which(name)
    if found is None:
        raise FileNotFoundError(f'executable {name!r} not found beside {sys.argv[0]} or on PATH')
    return found


def stop(procs, grace=(5.0, 3.0)):
    """Send SIGINT, SIGINT again, then SIGKILL, each after its deadline; return the exit codes."""
    for deadline in (*grace, None):
        alive = [p for p in procs if p.poll() is None]
        if not alive:
            break
        for p in alive:
            p.send_signal(signal.SIGKILL if deadline is None else signal.SIGINT)
        end = time.monotonic() + (deadline or 5.0)
        for p in alive:
            try:
                p.wait(timeout=max(0.0, end - time.monotonic()))
            except subprocess.TimeoutExpired:
                pass
    return [p.returncode for p in procs]


class Swarm:
    """The processes of one run; use as a context manager so they are always stopped."""

    def __init__(self, sc, mode='lockstep', real_time_factor=1.0, workdir=None,
                 wait_for_start=False, monitor=True, node_params=(), per_process=1, place=None,
                 env=None, monitor_params=(), namespace='/'):
        self.sc, self.mode = sc, mode
        self.place, self.env = place or (lambda name: []), env
        self.dir = Path(workdir or tempfile.mkdtemp(prefix='formation_swarm_'))
        self.dir.mkdir(parents=True, exist_ok=True)
        self.record = self.dir / 'run.npz'
        params = write_params(sc, self.dir / 'scenario.yaml', wait_for_start, namespace)
        prefix = namespace_prefix(namespace)
        names = ['-r', f'__ns:={prefix.rstrip("/")}'] if prefix != '/' else []
        common = ['--ros-args', *names, '--params-file', params, '-p', f'mode:={mode}']
        for p in node_params:
            common += ['-p', p]
        self.commands = [[executable('plant'), *common, '-p', f'record_path:={self.record}',
                          '-p', f'real_time_factor:={float(real_time_factor)}',
                          '-p', f'wait_for_start:={str(wait_for_start).lower()}']]
        self.logs = ['plant.log']
        ids = list(range(1, sc.num_vehicles + 1))
        for group in (ids[i:i + per_process] for i in range(0, len(ids), per_process)):
            if per_process == 1:
                self.commands.append([executable('vehicle'), *common, '-p',
                                      f'vehicle_id:={group[0]}'])
                self.logs.append(f'vehicle_{group[0]}.log')
            else:
                self.commands.append([executable('vehicles'), *common, '-p',
                                      f'vehicle_ids:={group}'])
                self.logs.append(f'vehicles_{group[0]}-{group[-1]}.log')
        if monitor:
            world = [a for p in node_params if p.startswith('world_frame:=') for a in ('-p', p)]
            self.commands.append([executable('monitor'), '--ros-args', *names,
                                  '-r', f'/clock:={prefix}clock', *world, '-p',
                                  f'use_sim_time:={str(mode == "lockstep").lower()}',
                                  *(a for p in monitor_params for a in ('-p', p))])
            self.logs.append('monitor.log')
        self.procs = []

    def __enter__(self):
        try:
            for cmd, name in zip(self.commands, self.logs):
                with open(self.dir / name, 'w') as log:
                    self.procs.append(subprocess.Popen(self.place(name[:-4]) + cmd, stdout=log,
                                                       stderr=subprocess.STDOUT, env=self.env,
                                                       stdin=subprocess.DEVNULL))
        except BaseException:
            stop(self.procs)
            raise
        return self

    def __exit__(self, *exc):
        stop(self.procs)

    @property
    def plant(self):
        return self.procs[0]

    def check(self):
        """Raise if a process other than the plant has exited while the plant runs."""
        for proc, name in zip(self.procs[1:], self.logs[1:]):
            if proc.poll() is not None:
                raise RuntimeError(f'{name[:-4]} exited with {proc.returncode} during the run:\n'
                                   + self.log_tail(name))

    def log_tail(self, name='plant.log', lines=20):
        text = (self.dir / name).read_text(errors='replace').splitlines()
        return '\n'.join(text[-lines:])

    def result(self):
        """Return the recorded run and its summary with the real-time factor."""
        run = simulator.load_run(self.record)
        out = simulator.summary(run)
        out['real_time_factor'] = run.meta['simulated_time'] / max(run.meta['wall_time'], 1e-9)
        out['mode'] = self.mode
        return run, out


def wait_plant(swarm, timeout, recorder=None):
    """Wait for the plant to finish (spinning the bag recorder meanwhile, then draining it)."""
    end = time.monotonic() + timeout
    if recorder is not None:
        recorder.start_when_discovered(timeout, swarm.check)
    while swarm.plant.poll() is None:
        swarm.check()
        if time.monotonic() > end:
            raise TimeoutError(f'the run did not finish within {timeout:g} s; plant log:\n'
                               + swarm.log_tail())
        if recorder is None:
            time.sleep(0.05)
        else:
            recorder.spin(0.05)
    if swarm.plant.returncode != 0:
        raise RuntimeError(f'the plant exited with {swarm.plant.returncode}:\n'
                           + swarm.log_tail())
    if recorder is not None:
        recorder.spin(1.0)


class Recording:
    """
    A bag recorder node on its own context, spun by :func:`wait_plant`.

    The plant holds step 0 until each of the recorder's readers is matched with a publisher of
    its topic (not merely discovered it), so the bag misses nothing.
    """

    def __init__(self, path, n, sim_time, monitor=True, namespace='/'):
        import rclpy
        from rclpy.experimental import EventsExecutor
        from rclpy.parameter import Parameter
        from std_msgs.msg import Empty

        from formation_control.ros.bag import BagRecorder, fleet_topics
        from formation_control.ros.interface import (CLOCK_TOPIC, LATCHED_QOS, MARKERS_TOPIC,
                                                     METRICS_TOPIC)
        from formation_control.ros.plant import START_TOPIC
        self.context = rclpy.Context()
        rclpy.init(context=self.context, signal_handler_options=rclpy.SignalHandlerOptions.NO)
        prefix = namespace_prefix(namespace)
        monitored = [prefix + t for t in (METRICS_TOPIC, MARKERS_TOPIC)]
        topics = [t for t in fleet_topics(n, prefix) if monitor or t[0] not in monitored]
        self.topics = [t for t, _, _ in topics if sim_time or t != prefix + CLOCK_TOPIC]
        self.node = BagRecorder(str(path), topics, context=self.context,
                                cli_args=['--ros-args', '-r', f'/clock:={prefix}clock'],
                                parameter_overrides=[Parameter('use_sim_time', value=sim_time)])
        self.start = self.node.create_publisher(Empty, prefix + START_TOPIC, LATCHED_QOS)
        self.start_msg = Empty()
        self.executor = EventsExecutor(context=self.context)
        self.executor.add_node(self.node)

    def start_when_discovered(self, timeout, check):
        end = time.monotonic() + timeout
        while any(self.node.readers[t].get_publisher_count() == 0 for t in self.topics):
            check()
            if time.monotonic() > end:
                raise TimeoutError('the bag recorder did not discover every topic in time')
            self.spin(0.05)
        self.start.publish(self.start_msg)

    def spin(self, seconds):
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            self.executor.spin_once(timeout_sec=max(0.0, end - time.monotonic()))

    def close(self, drain=1.0):
        self.spin(drain)
        self.node.close()
        self.node.destroy_node()
        self.context.try_shutdown()


def run_swarm(sc, mode='lockstep', bag=None, real_time_factor=1.0, timeout=None, workdir=None,
              monitor=True, node_params=(), per_process=1, place=None, env=None,
              monitor_params=(), namespace='/'):
    """
    Run a fleet as processes in ``namespace``; return (run, summary). Every process is stopped.

    ``monitor_params`` (``name:=value``) go to the monitor only (``foxglove_port``).
    ``place(name)`` gives the command prefix that starts process ``name`` (``plant``,
    ``vehicle_3``, ``vehicles_1-4``, ``monitor``) elsewhere, e.g. ``ip netns exec host``;
    ``env`` replaces the environment of every process.
    """
    timeout = timeout or 60.0 + 20.0 * sc.duration
    recording = None
    if bag is not None:
        if Path(bag).exists():
            raise FileExistsError(f'bag directory {bag} exists already')
        recording = Recording(bag, sc.num_vehicles, mode == 'lockstep', monitor, namespace)
    try:
        with Swarm(sc, mode, real_time_factor, workdir, recording is not None,
                   monitor, node_params, per_process, place, env, monitor_params,
                   namespace) as swarm:
            wait_plant(swarm, timeout, recording)
    finally:
        if recording is not None:
            recording.close()
    run, out = swarm.result()
    out['logs'] = str(swarm.dir)
    if bag is not None:
        out['bag'] = str(bag)
    return run, out


def environment_note():
    if 'ROS_AUTOMATIC_DISCOVERY_RANGE' not in os.environ:
        return ('note: ROS_AUTOMATIC_DISCOVERY_RANGE is unset; set it to LOCALHOST to keep '
                'discovery on this machine')
    return None
