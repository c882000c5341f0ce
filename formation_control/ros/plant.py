"""
``plant``: integrates the N vehicles of a scenario with the sampled-data loop of the offline
simulator (:class:`simulator.Stepper`) and broadcasts their state.

Lockstep (default): the plant owns ``/clock``; it publishes step n (clock, every odometry),
waits for the command of every vehicle stamped with step n, records, integrates one control
period, and publishes step n + 1. Real time: a wall timer advances one period every
``dt_control / real_time_factor`` seconds with the last command of each vehicle held.
"""
import sys
import time

import numpy as np
from geometry_msgs.msg import Vector3Stamped, WrenchStamped
from nav_msgs.msg import Odometry
from rcl_interfaces.msg import FloatingPointRange, ParameterDescriptor
from rclpy.node import Node
from rosgraph_msgs.msg import Clock
from std_msgs.msg import Empty, String

from formation_control.core import simulator
from formation_control.ros import interface as itf
from formation_control.ros import parameters

NODE_PARAMETERS = ('mode', 'real_time_factor', 'record_path', 'exit_when_done', 'wait_for_start')
START_TOPIC = '/formation/start'


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
        parameters.declare(self)
        parameters.reject_unknown(self, NODE_PARAMETERS)
        self.sc = sc = parameters.current(self)
        self.mode = parameters.choice(self, 'mode', parameters.MODES)
        for note in sc.warnings:
            self.get_logger().warn(note)
        self.stepper = simulator.Stepper(sc)
        self.recorder = simulator.Recorder(sc)
        self.n = 0
        self.wall_start = None
        self.t0_ns = 0
        self.started = self.done = False
        n = sc.num_vehicles
        self.pending = np.zeros((2, n))
        self.got = np.zeros(n, bool)
        self.odom_pubs = [self.create_publisher(Odometry, itf.topic(k, 'odom'), itf.STATE_QOS)
                          for k in range(1, n + 1)]
        self.flow_pubs = [self.create_publisher(Vector3Stamped, itf.topic(k, 'flow'),
                                                itf.LATCHED_QOS) for k in range(1, n + 1)]
        for k in range(1, n + 1):
            self.create_subscription(WrenchStamped, itf.topic(k, 'cmd'),
                                     lambda msg, k=k: self._on_cmd(k, msg), itf.STATE_QOS)
        self.clock_pub = None
        if self.mode == 'lockstep':
            self.clock_pub = self.create_publisher(Clock, '/clock', itf.LATCHED_QOS)
        for k, pub in enumerate(self.flow_pubs, start=1):
            pub.publish(itf.flow_msg(k, 0, sc.flow_c))
        self.scenario_pub = self.create_publisher(String, itf.SCENARIO_TOPIC, itf.LATCHED_QOS)
        self.scenario_pub.publish(itf.scenario_msg(sc))
        self.get_logger().info(f'plant: {n} x {sc.model}, {sc.formation} ({sc.controller}), '
                               f'{self.mode}, {sc.duration:g} s')
        if self.get_parameter('wait_for_start').value:
            self.create_subscription(Empty, START_TOPIC, self._start, itf.LATCHED_QOS)
        else:
            self._start()

    def _start(self, _msg=None):
        if self.started:
            return
        self.started = True
        if self.mode == 'realtime':
            self.t0_ns = self.get_clock().now().nanoseconds
            period = self.sc.dt_control / self.get_parameter('real_time_factor').value
            self.create_timer(period, self._on_timer)
        self._publish_step()

    def _step_ns(self):
        return self.t0_ns + int(round(self.n * self.sc.dt_control * 1e9))

    def _publish_step(self):
        ns = self._step_ns()
        if self.clock_pub is not None:
            msg = Clock()
            msg.clock.sec, msg.clock.nanosec = divmod(ns, 1_000_000_000)
            self.clock_pub.publish(msg)
        X = self.stepper.X
        for k, pub in enumerate(self.odom_pubs, start=1):
            pub.publish(itf.odom_msg(k, ns, X[:, k - 1], self.sc.flow_c))

    def _on_cmd(self, k, msg):
        u = itf.input_from_cmd(msg, self.sc.model)
        if not np.all(np.isfinite(u)):
            self.get_logger().warn(f'dropped a non-finite command of vehicle {k}',
                                   throttle_duration_sec=2.0)
            return
        if self.mode == 'lockstep':
            if not self.started or self.done or itf.stamp_ns(msg.header.stamp) != self._step_ns():
                return
            self.got[k - 1] = True
        self.pending[:, k - 1] = u
        if self.mode == 'lockstep' and self.got.all():
            self.got[:] = False
            self._advance()

    def _on_timer(self):
        if not self.done:
            self._advance()

    def _advance(self):
        if self.wall_start is None:
            self.wall_start = time.perf_counter()
        U = self.stepper.hold(self.pending)
        self.recorder.record(self.n, self.stepper.X, U)
        if self.n >= self.recorder.steps:
            return self._finish()
        self.stepper.advance()
        self.n += 1
        self._publish_step()

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
        self.done = self.get_parameter('exit_when_done').value


def main(args=None):
    from formation_control.ros.runner import run
    return run(lambda context: PlantNode(context=context), args)


if __name__ == '__main__':
    sys.exit(main())
