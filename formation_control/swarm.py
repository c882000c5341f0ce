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
from collections.abc import Callable, Mapping
from dataclasses import dataclass
import os
from pathlib import Path
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time

from formation_control.ops import dds_profile, lifetime, security, signing
from formation_control.protocol import faults, names
from formation_control.protocol.fleet_plan import (check_discovery, FleetPlan, ros_arguments,
                                                   SWARM_LABELS, write_params)
from formation_control.protocol.healing import HEAL_AFTER, Healer, Hearing, STARTUP
from formation_control.protocol.onboard import vehicle_topics
from formation_control.sim import simulator

CLOCK_EVENTS = 8
"""Supervisor events handled before each slice of recording (clock samples, service answers)."""
RECORD_SLICE = 0.005
"""Wall seconds of recording between two looks at the fleet time."""
VEHICLE_TOPIC = re.compile(r'/vehicle_(\d+)/')
GRAPH_PERIOD = 3.0
"""Wall seconds within which two plants heard in one namespace are two fleets (a plant speaks
on /diagnostics every second)."""


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
    for p in procs:
        if p.poll() is None:
            p.send_signal(signal.SIGCONT)              # a frozen process handles no SIGINT
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


def exit_text(code):
    """Describe an exit code: ``-9`` is ``-9 (SIGKILL)``."""
    if code is not None and code < 0:
        try:
            return f'{code} ({signal.Signals(-code).name})'
        except ValueError:
            pass
    return str(code)


def _at(t):
    return 't = ?' if t is None else f't = {t:.2f} s'


@dataclass(frozen=True)
class SwarmOptions:
    """
    How the processes of a fleet run, beside its :class:`FleetPlan` (what they are).

    Attributes
    ----------
    real_time_factor : float
        The plant's pacing in real time (fleet seconds per wall second).
    workdir : str or Path, optional
        Where the logs and the plant's record go (None: a new temporary directory).
    monitor : bool
        Run the ``monitor`` process.
    node_params : tuple of str
        ``name:=value`` for every node that takes the fleet's file.
    monitor_params : tuple of str
        ``name:=value`` for the monitor only (``foxglove_port``).
    place : callable, optional
        ``place(name)``: the command prefix that starts process ``name`` (``plant``,
        ``vehicle_3``, ``vehicles_1-4``, ``monitor``) elsewhere, e.g. ``ip netns exec host``.
        With one, the discovery check of a local fleet is left out.
    env : mapping, optional
        The environment of every process (None: this process's).
    restart_dead : float, optional
        Fleet seconds after which a vehicle or monitor process that died by itself is started
        again (None: never).
    secure : str or Path, optional
        The directory of a TLS fleet (:mod:`formation_control.ops.security`): each process
        runs as its member (the plan made with ``secure=True``).
    heal_after : float
        Wall seconds the fleet may wait on a live member before the member is restarted
        (:mod:`formation_control.protocol.healing`; 0: never).
    stop : threading.Event, optional
        Set, it ends the run as KeyboardInterrupt, every process stopped.

    """

    real_time_factor: float = 1.0
    workdir: str | Path | None = None
    monitor: bool = True
    node_params: tuple[str, ...] = ()
    monitor_params: tuple[str, ...] = ()
    place: Callable[[str], list[str]] | None = None
    env: Mapping[str, str] | None = None
    restart_dead: float | None = None
    secure: str | Path | None = None
    heal_after: float = HEAL_AFTER
    stop: threading.Event | None = None


class Swarm:
    """
    The processes of one run; use as a context manager so they are always stopped.

    A vehicle or monitor process that exits during the run is noted (:meth:`check`: fleet time,
    exit code, cause) and the others carry on; with ``restart_dead`` (fleet seconds) a process
    that died by itself is started again that long after. A live process the fleet waits on
    past ``heal_after`` is restarted (:meth:`heal`, noted in :attr:`healed`). Scripted faults
    act on the processes through :meth:`apply`.

    Parameters
    ----------
    sc : scenario.Scenario
    plan : FleetPlan
        The fleet's processes: its mode, namespace, vehicles per process, whether a bag records
        it (the plant waits for the start) and whether it is a TLS fleet.
    options : SwarmOptions
        How they run.

    """

    def __init__(self, sc, plan, options=SwarmOptions()):
        self.sc, self.mode, self.options = sc, plan.mode, options
        self.place = options.place or (lambda name: [])
        self.stop = options.stop
        self.dir = Path(options.workdir or tempfile.mkdtemp(prefix='formation_swarm_'))
        self.dir.mkdir(parents=True, exist_ok=True)
        self.record = self.dir / 'run.npz'
        params = write_params(sc, self.dir / 'scenario.yaml', plan.recorded, plan.prefix)
        self.prefix = prefix = plan.prefix
        remap = ['-r', f'__ns:={names.namespace_of(prefix)}'] if prefix != '/' else []
        fleet = ['--params-file', params, *ros_arguments(plan.common),
                 *(a for p in options.node_params for a in ('-p', p))]
        world = dict(p.split(':=', 1) for p in options.node_params
                     if p.startswith(('world_frame:=', 'base_frame:=')))
        processes = [plan.plant(record_path=self.record,
                                real_time_factor=float(options.real_time_factor)),
                     *plan.vehicles()]
        if options.monitor:
            processes.append(plan.monitor(**world))
        self.commands = [
            [executable(p.executable), '--ros-args', *remap, *(fleet if p.fleet else []),
             *(['-r', ':='.join(plan.clock)] if p.clock else []), *ros_arguments(p.parameters),
             *(a for m in options.monitor_params for a in ('-p', m) if p.name == 'monitor')]
            for p in processes]
        self.logs = [f'{p.name}.log' for p in processes]
        self.members = [p.vehicles for p in processes]
        self.names = [p.name for p in processes]
        self.envs = self._environments(plan, len(processes))
        self.process_of = {k: i for i, group in enumerate(self.members) for k in group}
        self.procs, self.state, self.cause = [], [], {}
        self.group = 0
        self.restart_dead, self.restarts = options.restart_dead, []
        self.t = None
        self.lost, self.faults, self.survivors = [], [], None
        self.healer = Healer(self.members, options.heal_after,
                             startup=STARTUP * len(self.members))
        self.healed = []

    def _environments(self, plan, count):
        """Return the environment of each process (its member's, in a TLS fleet), checked."""
        env, secure = self.options.env, self.options.secure
        base = os.environ if env is None else env
        if self.options.place is None:
            check_discovery(count + 1, self.sc.num_vehicles, plan.per_process, SWARM_LABELS[0],
                            base)
        if secure is None:
            profile = dds_profile.fleet_env(base, self.dir)
            env = {**base, **profile} if profile else env
            return dict.fromkeys(self.names, env)
        envs = {name: security.member_env(secure, name, base) for name in self.names}
        refused = [signing.check_member(e) for e in envs.values()]
        if any(refused):
            raise security.SecurityError(next(filter(None, refused)))
        return envs

    def __enter__(self):
        try:
            for i in range(len(self.commands)):
                self.procs.append(None)
                self.state.append('running')
                self._start(i, 'w')
        except BaseException:
            stop([p for p in self.procs if p is not None])
            raise
        return self

    def __exit__(self, *exc):
        stop(self.procs)

    def _start(self, i, mode='a'):
        """
        Start process ``i`` in the fleet's process group, tied to this process.

        The group (the first process's pid) is the fleet's alone: a frozen member is continued
        through it when this process dies (:mod:`formation_control.ops.lifetime`). A group
        whose members have all exited is made anew.
        """
        with open(self.dir / self.logs[i], mode) as log:
            for group in dict.fromkeys((self.group, 0)):
                try:
                    self.procs[i] = subprocess.Popen(
                        self.place(self.names[i]) + self.commands[i], stdout=log,
                        stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL, process_group=group,
                        env=lifetime.tied_env(self.envs[self.names[i]] or os.environ, True))
                    break
                except PermissionError:
                    continue
        self.group = group or self.procs[i].pid
        self.state[i] = 'running'
        self.healer.resumed(i, time.monotonic())

    @property
    def plant(self):
        return self.procs[0]

    def say(self, text):
        print(f'swarm: {_at(self.t)}: {text}', file=sys.stderr, flush=True)

    def check(self):
        """
        Note each vehicle or monitor process that has exited, and restart those that are due.

        A death is logged with the fleet time and kept in :attr:`lost`; the others carry on.
        Once the ``stop`` event is set (a signal handler's), raise KeyboardInterrupt here, in
        the waiting loop: raised from a signal handler inside an executor's callback, it would
        come out of rclpy as another error.
        """
        if self.stop is not None and self.stop.is_set():
            raise KeyboardInterrupt
        for i in range(1, len(self.procs)):
            code = self.procs[i].poll()
            if code is None or self.state[i] == 'dead':
                continue
            self.state[i] = 'dead'
            cause = self.cause.pop(i, None)
            self.lost.append({'process': self.names[i], 'vehicles': list(self.members[i]),
                              'time': self.t, 'exit': code, 'cause': cause or 'not scripted',
                              'restarted': None})
            again = ''
            if cause is None and self.restart_dead is not None:
                self.restarts.append(((self.t or 0.0) + self.restart_dead, i))
                again = f'; restarted at t = {(self.t or 0.0) + self.restart_dead:.2f} s'
            self.say(f'{self.names[i]} exited with {exit_text(code)} '
                     f'({cause or "not scripted"}); the others carry on{again}')
        due = [r for r in self.restarts if self.t is not None and r[0] <= self.t]
        for r in due:
            self.restarts.remove(r)
            self.restart(r[1])

    def note(self, fault):
        """Record and log a scripted fault applied at the current fleet time."""
        self.faults.append({'fault': fault.text, 'action': fault.describe(),
                            'scheduled': fault.time, 'applied': self.t})
        self.say(f'{fault.describe()} ({fault.text})')

    def restart(self, i, cause='restarted'):
        """Start process ``i`` again (killed first if it still runs, for ``cause``)."""
        if self.procs[i].poll() is None:
            self.cause[i] = cause
            self.procs[i].send_signal(signal.SIGCONT)
            self.procs[i].kill()
            self.procs[i].wait()
        self.check()
        self._start(i)
        for entry in self.lost[::-1]:
            if entry['process'] == self.names[i] and entry['restarted'] is None:
                entry['restarted'] = self.t
                break
        self.say(f'{self.names[i]} started again')

    def heal(self, plant_status, heard):
        """
        Restart the live members the fleet has waited on past ``heal_after`` (:class:`Healer`).

        ``plant_status`` is the plant's (step, {silent id: seconds waited}) just heard, or None;
        ``heard`` each vehicle's last :class:`~formation_control.protocol.healing.Heard`
        status. A process the fault script froze or killed is left to the script.
        """
        if plant_status is None:
            return
        running = [i for i in range(1, len(self.procs))
                   if self.state[i] == 'running' and self.procs[i].poll() is None]
        given_up = set(self.healer.given_up)
        for i, reason in self.healer.due(*plant_status, heard, running, time.monotonic()):
            self.healed.append({'process': self.names[i], 'vehicles': list(self.members[i]),
                                'time': self.t, 'reason': reason})
            self.say(f'healing {self.names[i]}: {reason}: restarted')
            self.restart(i, f'healed: {reason}')
        for i in sorted(self.healer.given_up - given_up):
            self.say(f'{self.names[i]} still holds the fleet after {self.healer.limit} '
                     f'restarts: left as it is')

    def apply(self, fault):
        """Apply a scripted process fault (:class:`faults.Fault`) now; record it."""
        self.note(fault)
        if fault.kind in faults.LINK_KINDS:
            return
        i = self.process_of[fault.vehicles[0]]
        if fault.kind == 'restart':
            return self.restart(i)
        if self.state[i] == 'dead' or self.procs[i].poll() is not None:
            self.faults[-1]['applied'] = None
            return self.say(f'{self.names[i]} is not running: {fault.text} not applied')
        if fault.kind == 'kill':
            self.cause[i] = f'fault {fault.text}'
            self.procs[i].kill()
        else:
            self.procs[i].send_signal(signal.SIGSTOP if fault.kind == 'stop' else signal.SIGCONT)
            self.state[i] = 'stopped' if fault.kind == 'stop' else 'running'
            self.healer.resumed(i, time.monotonic())

    def running_vehicles(self):
        """Return the ids of the vehicles whose process runs (not dead, not frozen)."""
        return sorted(k for k, i in self.process_of.items()
                      if self.state[i] == 'running' and self.procs[i].poll() is None)

    def log_tail(self, name='plant.log', lines=20):
        text = (self.dir / name).read_text(errors='replace').splitlines()
        return '\n'.join(text[-lines:])

    def result(self):
        """Return the recorded run and its summary with the real-time factor and the faults."""
        run = simulator.load_run(self.record)
        out = simulator.summary(run)
        out['real_time_factor'] = run.meta['simulated_time'] / max(run.meta['wall_time'], 1e-9)
        out['mode'] = self.mode
        out['faults'], out['lost'], out['healed'] = self.faults, self.lost, self.healed
        out['survivors'] = self.survivors
        out['survivors_converged'], out['survivors_convergence_time'] = \
            faults.survivors_converged(run, self.survivors)
        return run, out


def wait_plant(swarm, timeout, supervisor=None, schedule=None):
    """
    Wait for the plant to finish; a dead plant raises with its log, a dead vehicle does not.

    The ``supervisor`` (:class:`Supervisor`) is spun meanwhile: fleet time, the bag, the
    ``schedule`` of scripted faults (:class:`faults.Schedule`) applied as fleet time passes.
    """
    end = time.monotonic() + timeout
    if supervisor is not None and supervisor.recorder is not None:
        supervisor.start_when_discovered(timeout, swarm)
    elif supervisor is not None and supervisor.start is not None:
        supervisor.start_when_clocked(timeout, swarm)
    while swarm.plant.poll() is None:
        swarm.check()
        if time.monotonic() > end:
            raise TimeoutError(f'the run did not finish within {timeout:g} s; plant log:\n'
                               + swarm.log_tail())
        if supervisor is None:
            time.sleep(0.05)
            continue
        supervisor.spin_once(0.02)
        if supervisor.recorder is not None and supervisor.recorder.failure is not None:
            raise RuntimeError(supervisor.recorder.failure)
        swarm.t = supervisor.t
        swarm.heal(supervisor.hearing.take_plant_status(), supervisor.hearing.heard)
        for fault in schedule.due(swarm.t) if schedule and swarm.t is not None else ():
            swarm.apply(fault)
            if fault.kind in faults.LINK_KINDS:
                supervisor.cut_links(schedule.cut_links(fault))
            supervisor.publish(fault, swarm.faults[-1])
    if swarm.plant.returncode != 0:
        raise RuntimeError(f'the plant exited with {swarm.plant.returncode}:\n'
                           + swarm.log_tail())
    swarm.check()
    swarm.survivors = swarm.running_vehicles()
    if supervisor is not None and supervisor.recorder is not None:
        supervisor.spin(1.0)


class Supervisor:
    """
    The swarm's own node, on its own context: fleet time, faults, the bag, whom the fleet awaits.

    Whom the fleet awaits is what the plant and the vehicles say on ``/diagnostics``
    (:meth:`Swarm.heal`).

    Fleet time is the fleet's ``clock`` in lockstep, and in real time vehicle 1's odometry
    stamps from the first one heard (the supervisor exists before the plant starts); every name
    is in the fleet's ``namespace``. Each applied fault is
    published on :data:`names.FAULTS_TOPIC` (formation_control_msgs/FaultEvent, latched) and so
    recorded. With a bag, the plant holds step 0 until each of the recorder's readers is matched
    with a publisher of its topic (not merely discovered it), so the bag misses nothing.
    """

    def __init__(self, n, mode, bag=None, monitor=True, namespace='/',
                 vehicle_topics=names.KNOWN_FLOW_TOPICS, starts=False):
        from diagnostic_msgs.msg import DiagnosticArray
        from formation_control_msgs.msg import FaultEvent
        from nav_msgs.msg import Odometry
        import rclpy
        from rclpy.experimental import EventsExecutor
        from rclpy.node import Node
        from rclpy.parameter import Parameter
        from rosgraph_msgs.msg import Clock
        from std_msgs.msg import Empty

        from formation_control.ros import interface as itf
        from formation_control.ros.bag import BagRecorder, FAULT_EVENT, fleet_topics
        from formation_control.ros.common import Rejections, subscribe_messages
        self.Parameter, self.Empty = Parameter, Empty
        self.prefix = prefix = names.namespace_prefix(namespace)
        self.t, self.t0 = None, None
        self.context = rclpy.Context()
        rclpy.init(context=self.context, signal_handler_options=rclpy.SignalHandlerOptions.NO)
        self.executor = EventsExecutor(context=self.context)
        self.node = Node('formation_swarm', context=self.context,
                         start_parameter_services=False)
        self.executor.add_node(self.node)
        self.fault_pub = self.node.create_publisher(FaultEvent, prefix + names.FAULTS_TOPIC,
                                                    itf.FAULTS_QOS)
        if mode == 'lockstep':
            self.time_sub = subscribe_messages(
                self.node, Clock, prefix + names.CLOCK_TOPIC, self._on_clock,
                Rejections(self.node.get_logger(), ['malformed']), qos_profile=itf.LATCHED_QOS)
        else:
            self.wire = itf.odom_wire(1)
            self.time_sub = self.node.create_subscription(
                Odometry, prefix + names.topic(1, 'odom'), self._on_odom, itf.STATE_QOS,
                raw=True)
        self.start = None
        if bag is not None or starts:
            self.start = self.node.create_publisher(Empty, prefix + names.START_TOPIC,
                                                    itf.LATCHED_QOS)
        self.hearing = Hearing(namespace)
        self.node.create_subscription(DiagnosticArray, names.DIAGNOSTICS_TOPIC,
                                      self._on_diagnostics, itf.STREAM_QOS)
        self.params = {}
        self.recorder = None
        if bag is not None:
            monitored = [prefix + t for t in (names.METRICS_TOPIC, names.MARKERS_TOPIC)]
            topics = [t for t in fleet_topics(n, prefix, vehicle_topics)
                      if monitor or t[0] not in monitored]
            topics.append((prefix + names.FAULTS_TOPIC, FAULT_EVENT, itf.FAULTS_QOS))
            self.topics = [t for t, _, _ in topics
                           if mode == 'lockstep' or t != prefix + names.CLOCK_TOPIC]
            try:
                self.recorder = BagRecorder(
                    str(bag), topics, context=self.context,
                    cli_args=['--ros-args', '-r', f'/clock:={prefix}clock'],
                    parameter_overrides=[Parameter('use_sim_time', value=mode == 'lockstep')])
            except RuntimeError:
                self.close()
                raise
            self.recording = EventsExecutor(context=self.context)
            self.recording.add_node(self.recorder)

    def _on_clock(self, msg):
        self.t = msg.clock.sec + 1e-9 * msg.clock.nanosec

    def _on_odom(self, data):
        got = self.wire.decode(data)
        if got is None:
            return
        if self.t0 is None:
            self.t0 = got[0]
        self.t = max(self.t or 0.0, 1e-9 * (got[0] - self.t0))

    def _on_diagnostics(self, msg):
        """Keep the plant's silent vehicles and each vehicle's awaited neighbours."""
        now = time.monotonic()
        for s in msg.status:
            self.hearing.hear(s.name, {kv.key: kv.value for kv in s.values}, now)

    def publish(self, fault, record):
        """Publish one applied fault (:class:`faults.Fault`, its record) on the faults topic."""
        from formation_control.ros import interface as itf
        self.fault_pub.publish(itf.fault_msg(fault, record, time.time_ns()))

    def cut_links(self, values):
        """Set ``cut_links`` of each vehicle of ``values`` ({id: ids}): its parameter service."""
        from rcl_interfaces.srv import SetParameters
        for k, ids in values.items():
            client = self.params.get(k)
            if client is None:
                client = self.params[k] = self.node.create_client(
                    SetParameters, f'{self.prefix}vehicle_{k}/set_parameters')
            request = SetParameters.Request(parameters=[self.Parameter(
                'cut_links', self.Parameter.Type.INTEGER_ARRAY, list(ids)).to_parameter_msg()])
            client.call_async(request).add_done_callback(
                lambda future, k=k: self._cut_done(k, future))

    def _cut_done(self, k, future):
        results = future.result().results if future.result() else []
        if not results or not results[0].successful:
            reason = results[0].reason if results else 'no answer'
            print(f'swarm: vehicle {k} refused cut_links: {reason}', file=sys.stderr)

    def start_when_discovered(self, timeout, swarm):
        """
        Start the plant once the recorder has matched every topic; heal a member it cannot.

        The vehicles whose topics have no publisher are the fleet's silent ones at step 0
        (:meth:`Swarm.heal`), the plant not yet started.
        """
        start = time.monotonic()
        end = start + timeout
        while unmatched := [t for t in self.topics
                            if self.recorder.readers[t].get_publisher_count() == 0]:
            swarm.check()
            ids = sorted({int(m[1]) for t in unmatched if (m := VEHICLE_TOPIC.search(t))})
            swarm.heal((0, dict.fromkeys(ids, time.monotonic() - start)), self.hearing.heard)
            if time.monotonic() > end:
                raise TimeoutError('the bag recorder did not discover every topic in time: '
                                   f'{unmatched[:5]} have no publisher')
            self.spin(0.05)
        self.start.publish(self.Empty())

    def start_when_clocked(self, timeout, swarm):
        """
        Start the plant once this node hears the fleet's time (scripted faults act on it).

        A lockstep fleet runs ahead of a supervisor still discovering its clock: a fault
        scripted at 1 s was once applied at 6.9 s, after the fleet had converged.
        """
        end = time.monotonic() + timeout
        while self.time_sub.get_publisher_count() == 0:
            swarm.check()
            if time.monotonic() > end:
                raise TimeoutError('the time of the fleet was not heard in time: no plant '
                                   'started')
            self.spin(0.05)
        self.start.publish(self.Empty())

    def spin_once(self, timeout):
        """
        Handle the fleet time and the faults' calls first, then the bag for up to ``timeout`` s.

        The recorder has its own executor: behind a lockstep fleet's stream of samples it may
        lag, and fleet time must not lag with it.
        """
        self.check_alone()
        if self.recorder is None:
            return self.executor.spin_once(timeout_sec=timeout)
        for _ in range(CLOCK_EVENTS):
            self.executor.spin_once(timeout_sec=0.0)
        end = time.monotonic() + min(timeout, RECORD_SLICE)
        while time.monotonic() < end:
            self.recording.spin_once(timeout_sec=max(0.0, end - time.monotonic()))

    def check_alone(self):
        """
        Raise if another fleet's plant speaks in this fleet's namespace of the domain.

        Two plants heard within :data:`GRAPH_PERIOD` wall seconds (their statuses' ``run``
        identities differ) publish the same vehicles' odometry: each fleet's vehicles would fly
        on both, and refuse the other's scenario.
        """
        plants = self.hearing.plants_within(GRAPH_PERIOD, time.monotonic())
        if len(plants) > 1:
            raise RuntimeError(
                f'another fleet runs in ROS_DOMAIN_ID {self.context.get_domain_id()}, namespace '
                f'{names.namespace_of(self.prefix)} (plants {", ".join(plants)} both speak): '
                f'both fleets publish the same topics; give one another ROS_DOMAIN_ID or '
                f'--namespace')

    def spin(self, seconds):
        end = time.monotonic() + seconds
        while True:
            self.spin_once(max(0.0, end - time.monotonic()))
            if time.monotonic() >= end:
                break

    def close(self, drain=1.0):
        """
        Stop recording, then destroy the nodes, executors and context: the DDS participant.

        Left to the end of the process, a TLS participant is destroyed after OpenSSL's own
        clean-up, and Fast DDS 2.14 crashes reconnecting to its peers (seen: SIGSEGV).
        """
        failed = None
        if self.recorder is not None:
            if self.recorder.failure is None:
                self.spin(drain)
            try:
                self.recorder.close()
            except RuntimeError as err:
                failed = err
            self.recording.shutdown()
            self.recorder.destroy_node()
        self.executor.shutdown()
        self.node.destroy_node()
        self.context.try_shutdown()
        self.context.destroy()
        if failed is not None:
            raise failed


def run_swarm(sc, options=SwarmOptions(), mode='lockstep', per_process=1, namespace='/',
              bag=None, fault_script=(), timeout=None):
    """
    Run a fleet as processes in ``namespace``; return (run, summary). Every process is stopped.

    ``options`` say how its processes run (:class:`SwarmOptions`). ``per_process``: vehicle
    nodes per process, or ``'auto'``
    (:func:`~formation_control.protocol.fleet_plan.auto_per_process`). ``bag``: a new bag
    directory the fleet is recorded into. ``fault_script`` lists the faults
    (:func:`faults.schedule`). In a TLS fleet (``options.secure``) this process runs as member
    ``swarm`` (its environment is changed: call it before this process has made a DDS
    participant).
    """
    timeout = timeout or 60.0 + 20.0 * sc.duration
    schedule = faults.schedule(fault_script, sc)
    if bag is not None and Path(bag).exists():
        raise FileExistsError(f'bag directory {bag} exists already')
    secure = options.secure
    swarm = Swarm(sc, FleetPlan(sc.num_vehicles, mode, per_process, namespace, secure is not None,
                                bag is not None, process_faults=schedule.acts_on_processes,
                                held=bool(schedule)),
                  options)
    print(f"swarm: logs and the plant's record {swarm.record} in {swarm.dir}", file=sys.stderr,
          flush=True)
    if secure is not None:
        os.environ.update(security.environment(secure, 'swarm'))
        for name in security.UNSET:
            os.environ.pop(name, None)
    with dds_profile.given(None if secure else swarm.dir):
        supervisor = Supervisor(sc.num_vehicles, mode, bag, options.monitor, namespace,
                                vehicle_topics(sc), starts=bool(schedule))
    try:
        with swarm:
            wait_plant(swarm, timeout, supervisor, schedule)
    finally:
        supervisor.close()
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
