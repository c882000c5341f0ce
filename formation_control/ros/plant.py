"""
``plant``: integrates the N vehicles of a scenario with the sampled-data loop of the offline
simulator (:class:`simulator.Stepper`) and broadcasts their state.

Lockstep (default): the plant owns ``/clock``; it publishes step n (clock, every odometry),
waits for the command of every vehicle stamped with step n, records, integrates one control
period, and publishes step n + 1. Real time: a wall timer advances one integration step every
``dt_integration / real_time_factor`` seconds with the last command of each vehicle held, and
vehicle k's odometry is sampled and sent at integration step (k - 1) mod substeps of each control
period, as unsynchronised sensors would: the vehicles' control callbacks are spread over the
period instead of all waking at once (docs/benchmarks.md, section 4). Simulated time starts once
every vehicle is up (a writer on each command topic; ``wait_for_fleet``), so a fleet that takes
seconds to start does not drift uncommanded meanwhile.

A vehicle that was heard and then sends no command for ``command_timeout`` wall seconds is gone:
its command is zero, and lockstep stops waiting for it until it speaks again (a vehicle never
heard is waited for). A vehicle whose state becomes non-finite is stopped (frozen, no more
odometry) with an error naming it. Counts and status: ``/diagnostics``, ``formation_control/plant``.
"""
import sys
import time

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue

import numpy as np
from geometry_msgs.msg import Vector3Stamped, WrenchStamped
from nav_msgs.msg import Odometry
from rcl_interfaces.msg import FloatingPointRange, ParameterDescriptor
from rclpy.clock import Clock as WallClock, ClockType
from rclpy.node import Node
from rosgraph_msgs.msg import Clock
from std_msgs.msg import Empty, String

from formation_control.core import links, simulator
from formation_control.ros import interface as itf
from formation_control.ros import parameters

NODE_PARAMETERS = ('mode', 'real_time_factor', 'record_path', 'exit_when_done', 'wait_for_start',
                   'wait_for_fleet', 'command_timeout')
START_TOPIC = '/formation/start'
NUDGE_AFTER = 4.0


class PlantNode(Node):
    """Rigid-body and flowfield dynamics of the whole fleet."""

    def __init__(self, **kwargs):
        super().__init__('plant', **kwargs)
        self.declare_parameter('mode', 'lockstep', ParameterDescriptor(
            description='lockstep (plant owns /clock, waits for every command) | realtime',
            read_only=True))
        self.declare_parameter('real_time_factor', 1.0, ParameterDescriptor(
            description='realtime mode: simulated seconds per wall second', read_only=True,
            floating_point_range=[FloatingPointRange(from_value=0.01, to_value=1000.0)]))
        self.declare_parameter('record_path', '', ParameterDescriptor(
            description='write the run here as .npz (simulator layout) when it ends',
            read_only=True))
        self.declare_parameter('exit_when_done', True, ParameterDescriptor(
            description='exit once duration is simulated', read_only=True))
        self.declare_parameter('wait_for_start', False, ParameterDescriptor(
            description=f'hold step 0 until a std_msgs/Empty on {START_TOPIC} (lets a recorder '
                        'discover every topic first)', read_only=True))
        self.declare_parameter('wait_for_fleet', True, ParameterDescriptor(
            description='realtime mode: hold t = 0 until every vehicle has a writer on its '
                        'command topic', read_only=True))
        parameters.declare(self)
        parameters.reject_unknown(self, NODE_PARAMETERS)
        self.sc = sc = parameters.current(self)
        self.mode = parameters.choice(self, 'mode', parameters.MODES)
        for note in sc.warnings:
            self.get_logger().warn(note)
        timeout = parameters.declare_links(self, ('command_timeout',), sc.num_vehicles)
        self.liveness = links.Liveness(sc.num_vehicles, timeout['command_timeout'])
        self.wall = WallClock(clock_type=ClockType.STEADY_TIME)
        self.stopped = np.zeros(sc.num_vehicles, bool)
        self.step_since = np.inf if self.mode == 'lockstep' else -np.inf
        self.counts = {'non_finite': 0, 'wrong_frame': 0, 'stale': 0}
        self.repeated = 0
        self.step_wall, self.nudged, self.nudges, self.step_nudges = 0.0, -np.inf, 0, 0
        self.stepper = simulator.Stepper(sc)
        self.recorder = simulator.Recorder(sc)
        self.n = 0
        self.wall_start = None
        self.t0_ns = 0
        self.started = self.finished = self.done = False
        n = sc.num_vehicles
        self.pending = np.zeros((2, n))
        self.got = np.zeros(n, bool)
        self.cmd_ns = np.full(n, -1, np.int64)
        self.odom_pubs = [self.create_publisher(Odometry, itf.topic(k, 'odom'), **itf.state_qos_kwargs())
                          for k in range(1, n + 1)]
        self.flow_pubs = [self.create_publisher(Vector3Stamped, itf.topic(k, 'flow'),
                                                itf.LATCHED_QOS) for k in range(1, n + 1)]
        self.cmd_subs = [self.create_subscription(WrenchStamped, itf.topic(k, 'cmd'),
                                                  lambda msg, k=k: self._on_cmd(k, msg),
                                                  **itf.state_qos_kwargs())
                         for k in range(1, n + 1)]
        self.clock_pub = None
        if self.mode == 'lockstep':
            self.clock_pub = self.create_publisher(Clock, '/clock', itf.LATCHED_QOS)
        for k, pub in enumerate(self.flow_pubs, start=1):
            pub.publish(itf.flow_msg(k, 0, sc.flow_c))
        self.scenario_pub = self.create_publisher(String, itf.SCENARIO_TOPIC, itf.LATCHED_QOS)
        self.scenario_pub.publish(itf.scenario_msg(sc))
        self.get_logger().info(f'plant: {n} x {sc.model}, {sc.formation} ({sc.controller}), '
                               f'{self.mode}, {sc.duration:g} s')
        self.diag_pub = self.create_publisher(DiagnosticArray, itf.DIAGNOSTICS_TOPIC, itf.STREAM_QOS)
        self.create_timer(1.0, self._publish_diagnostics, clock=self.wall)
        if self.mode == 'lockstep':
            self.create_timer(min(0.05, self.liveness.timeout / 4), self._try_advance,
                              clock=self.wall)
        if self.get_parameter('wait_for_start').value:
            self.create_subscription(Empty, START_TOPIC, self._start, itf.LATCHED_QOS)
        else:
            self._start()

    def _start(self, _msg=None):
        if self.started:
            return
        self.started = True
        if self.mode == 'lockstep':
            return self._publish_step()
        if self.get_parameter('wait_for_fleet').value:
            self.missing = None
            self.fleet_timer = self.create_timer(0.05, self._start_when_fleet_is_up,
                                                 clock=self.wall)
        else:
            self._start_clock()

    def _start_when_fleet_is_up(self):
        missing = [k for k, sub in enumerate(self.cmd_subs, start=1)
                   if sub.get_publisher_count() == 0]
        if missing != self.missing:
            self.missing = missing
            self.get_logger().info(f'real time starts once vehicles {missing} are up'
                                   if missing else 'every vehicle is up: real time starts')
        if missing:
            return
        self.destroy_timer(self.fleet_timer)
        self._start_clock()

    def _start_clock(self):
        """Real time: t = 0 now; the first integration step is one tick away."""
        self.t0_ns = self.get_clock().now().nanoseconds
        self.t0_wall = self._now()
        self.tick_rate = self.get_parameter('real_time_factor').value / self.sc.dt_integration
        self.create_timer(1.0 / self.tick_rate, self._on_tick, clock=self.wall)
        self.slot = np.arange(self.sc.num_vehicles) % self.sc.substeps
        self.tick = 0
        self._publish_odom((self.slot == 0) & ~self.stopped, self.t0_ns)

    def _step_ns(self):
        return self._stamp_ns(self.n * self.sc.dt_control)

    def _stamp_ns(self, t):
        """The stamp of simulated time ``t`` (s)."""
        return self.t0_ns + int(round(t * 1e9))

    def _gone(self):
        return self.liveness.gone(self._now(), self.step_since, self.got)

    def _publish_step(self):
        ns = self._step_ns()
        if self.mode == 'lockstep':
            now = self._now()
            self.step_wall, self.step_since = now - self.step_since, now
            self.nudged, self.step_nudges = now, 0
        if self.clock_pub is not None:
            msg = Clock()
            msg.clock.sec, msg.clock.nanosec = divmod(ns, 1_000_000_000)
            self.clock_pub.publish(msg)
        self._publish_odom(~self.stopped, ns)

    def _publish_odom(self, which, ns):
        X = self.stepper.X
        for i in np.flatnonzero(which):
            self.odom_pubs[i].publish(itf.odom_msg(i + 1, ns, X[:, i], self.sc.flow_c))

    def _nudge(self, waited):
        """
        Lockstep: send this step's odometry again to the vehicles that have not answered, once
        the step has lasted NUDGE_AFTER times the last one (at least a second), then after
        twice that wait, and so on (a slow start-up of a large fleet is not flooded). A vehicle
        that hears the same step twice sends its state (and command) again, so a sample that DDS
        matched but never handed over (seen at start-up with many processes) cannot stall the
        fleet. Counted in ``/diagnostics``: ``nudges``, and the second answers as
        ``repeated_commands``.
        """
        now = self._now()
        wait = max(1.0, NUDGE_AFTER * self.step_wall) * 2.0 ** self.step_nudges
        if now - self.nudged > wait:
            self.nudged = now
            self.nudges += 1
            self.step_nudges += 1
            self._publish_odom(waited & ~self.got, self._step_ns())

    def _now(self):
        return self.wall.now().nanoseconds * 1e-9

    def _reject(self, kind, what):
        self.counts[kind] += 1
        self.get_logger().warn(f'dropped {what} ({kind}; total dropped: '
                               f'{sum(self.counts.values())})', throttle_duration_sec=2.0)

    def _on_cmd(self, k, msg):
        u = itf.input_from_cmd(msg, self.sc.model)
        if not np.all(np.isfinite(u)):
            return self._reject('non_finite', f'a non-finite command of vehicle {k}')
        if msg.header.frame_id != itf.base_link(k):
            return self._reject('wrong_frame', f'a command on vehicle {k}\'s topic in frame '
                                f'{msg.header.frame_id!r}')
        self.liveness.heard(k - 1, self._now())
        if self.mode == 'lockstep':
            ns = itf.stamp_ns(msg.header.stamp)
            if ns == self.cmd_ns[k - 1]:                  # the answer to a step asked again
                self.repeated += 1
                return
            if not self.started or self.finished or ns != self._step_ns():
                return self._reject('stale', f'a command of vehicle {k} for another step')
            self.got[k - 1], self.cmd_ns[k - 1] = True, ns
        self.pending[:, k - 1] = u
        self._try_advance()

    def _try_advance(self):
        """Lockstep: advance once every vehicle still waited for has commanded this step."""
        if self.mode != 'lockstep' or not self.started or self.finished:
            return
        gone = self._gone()
        waited = ~gone & ~self.stopped
        if waited.any() and np.all(self.got[waited]):
            self.got[:] = False
            self._advance(gone)
        else:
            self._nudge(waited)

    def _on_tick(self):
        """
        Real time: the integration steps the wall clock has reached (a late timer skips its
        missed periods, so count them), each followed by the odometry of the vehicles it samples.
        More than a control period behind, the machine is overloaded: simulated time slips
        rather than the commands waiting behind a long catch-up.
        """
        due = int((self._now() - self.t0_wall) * self.tick_rate)
        behind = due - self.tick - self.sc.substeps
        if behind > 0:
            self.t0_wall += behind / self.tick_rate
            due -= behind
        while self.tick < due and not self.finished:
            self._step_once()

    def _step_once(self):
        substeps = self.sc.substeps
        if not self._hold(self._gone(), self.tick % substeps == 0):
            return
        self._integrate(1)
        self.tick += 1
        self.n = self.tick // substeps
        self._publish_odom((self.slot == self.tick % substeps) & ~self.stopped,
                           self._stamp_ns(self.tick * self.sc.dt_integration))

    def _advance(self, gone):
        if self._hold(gone, True):
            self._integrate()
            self.n += 1
            self._publish_step()

    def _hold(self, gone, boundary):
        """Hold the commands; at a period boundary record, and finish after the last one."""
        if self.wall_start is None:
            self.wall_start = time.perf_counter()
        self.pending[:, gone | self.stopped] = 0.0
        U = self.stepper.hold(self.pending)
        if boundary:
            self.recorder.record(self.n, self.stepper.X, U)
            if self.n >= self.recorder.steps:
                self._finish()
                return False
        return True

    def _integrate(self, steps=None):
        before = self.stepper.X                             # advance returns a new array
        self._stop_non_finite(before, self.stepper.advance(steps))

    def _stop_non_finite(self, before, X):
        bad = ~np.all(np.isfinite(X), axis=0) & ~self.stopped
        for i in np.flatnonzero(bad):
            self.get_logger().error(f'vehicle {i + 1}: its state became non-finite after t = '
                                    f'{self.n * self.sc.dt_control:.3f} s (command '
                                    f'{self.pending[:, i].tolist()}); vehicle {i + 1} is stopped')
        self.stopped |= bad
        X[:, self.stopped] = before[:, self.stopped]

    def _report_waiting(self):
        """Say which commands a lockstep step has waited for more than itf.STALL seconds."""
        waited = self._now() - self.step_since
        if self.mode == 'lockstep' and not self.finished and waited > itf.STALL:
            missing = np.flatnonzero(~self._gone() & ~self.stopped & ~self.got) + 1
            self.get_logger().warn(f'step {self.n}: waiting {waited:.1f} s for the commands of '
                                   f'vehicles {missing.tolist()}', throttle_duration_sec=5.0)

    def _publish_diagnostics(self):
        self._report_waiting()
        gone = [int(i) + 1 for i in np.flatnonzero(self._gone())]
        stopped = [int(i) + 1 for i in np.flatnonzero(self.stopped)]
        level, text = DiagnosticStatus.OK, f'step {self.n}'
        if gone:
            level, text = DiagnosticStatus.WARN, f'vehicles {gone} gone (zero command)'
        if stopped:
            level, text = DiagnosticStatus.ERROR, f'vehicles {stopped} stopped: non-finite state'
        values = {'step': self.n, 'gone': gone, 'stopped': stopped, **self.counts,
                  'nudges': self.nudges, 'repeated_commands': self.repeated}
        status = DiagnosticStatus(level=level, name='formation_control/plant', message=text,
                                  values=[KeyValue(key=k, value=str(v))
                                          for k, v in values.items()])
        msg = DiagnosticArray(status=[status])
        msg.header.stamp = self.get_clock().now().to_msg()
        self.diag_pub.publish(msg)

    def _finish(self):
        wall = time.perf_counter() - self.wall_start
        simulated = self.n * self.sc.dt_control
        path = self.get_parameter('record_path').value
        if path:
            run = self.recorder.run()
            run.meta = {'mode': self.mode, 'wall_time': wall, 'simulated_time': simulated}
            run.save(path)
        self.get_logger().info(f'plant: {simulated:g} s simulated in {wall:.3g} s of wall time '
                               f'(real-time factor {simulated / max(wall, 1e-9):.3g})')
        self.finished = True
        self.done = self.get_parameter('exit_when_done').value


def main(args=None):
    from formation_control.ros.runner import run
    return run(lambda context: PlantNode(context=context), args)


if __name__ == '__main__':
    sys.exit(main())
