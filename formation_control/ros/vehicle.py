"""
``vehicle``: one vehicle's decentralised controller (a node per vehicle).

It hears its own odometry and flow, publishes its ``formation_state`` (pose, heading, yaw
rate and the phase values of the law), hears the formation states of its neighbours, and
publishes its own command. It knows nothing of the others but what it receives.

Lockstep: the command for step t is computed once the vehicle holds its own odometry and every
neighbour's state stamped t. Real time: a timer computes it from the latest states received.
"""
import math
import sys

import numpy as np
from rcl_interfaces.msg import ParameterDescriptor
from rclpy.node import Node
from geometry_msgs.msg import Vector3Stamped, WrenchStamped
from nav_msgs.msg import Odometry
from sensor_msgs.msg import JointState

from formation_control.core import laws
from formation_control.core.control import Controller
from formation_control.core.scenario import ScenarioError
from formation_control.ros import interface as itf
from formation_control.ros import parameters


class VehicleNode(Node):
    """The controller of vehicle ``vehicle_id`` (1..N)."""

    def __init__(self, vehicle_id, **kwargs):
        super().__init__(f'vehicle_{vehicle_id}', **kwargs)
        self.k = vehicle_id
        self.declare_parameter('vehicle_id', vehicle_id, ParameterDescriptor(
            description='this vehicle\'s id k, 1..num_vehicles', read_only=True))
        self.declare_parameter('mode', 'lockstep', ParameterDescriptor(
            description='lockstep (event-driven, sim time) | realtime (own timer)',
            read_only=True))
        parameters.declare(self)
        parameters.reject_unknown(self, ('vehicle_id', 'mode'))
        self.sc = parameters.current(self)
        self.mode = parameters.choice(self, 'mode', parameters.MODES)
        if not 1 <= vehicle_id <= self.sc.num_vehicles:
            raise ScenarioError(f"parameter 'vehicle_id' = {vehicle_id} is invalid: must lie in "
                                f'1..num_vehicles = {self.sc.num_vehicles}')
        self.ctrl = Controller(self.sc)
        n = self.sc.num_vehicles
        self.r = np.zeros(n, complex)
        self.table = np.zeros((3, n))                     # phase, rate, speed
        self.stamp = np.full(n, -1, np.int64)
        self.speed_dot = 0.0
        self.X = None
        self.odom_ns = self.commanded_ns = -1
        self.F_held = np.zeros(1)
        self.flow = self.sc.flow_c
        self.rejected = 0
        self.state_pub = self.create_publisher(JointState, itf.topic(self.k, 'formation_state'),
                                               itf.STATE_QOS)
        self.cmd_pub = self.create_publisher(WrenchStamped, itf.topic(self.k, 'cmd'),
                                             itf.STATE_QOS)
        self.create_subscription(Odometry, itf.topic(self.k, 'odom'), self._on_odom,
                                 itf.STATE_QOS)
        self.create_subscription(Vector3Stamped, itf.topic(self.k, 'flow'), self._on_flow,
                                 itf.LATCHED_QOS)
        for j in range(1, n + 1):
            if j != self.k:
                self.create_subscription(JointState, itf.topic(j, 'formation_state'),
                                         lambda msg, j=j: self._on_state(j, msg), itf.STATE_QOS)
        self.add_on_set_parameters_callback(parameters.validator(self))
        self.add_post_set_parameters_callback(self._apply_parameters)
        if self.mode == 'realtime':
            self.create_timer(self.sc.dt_control, self._on_timer)
        self.get_logger().info(f'vehicle {self.k}/{n}: {self.sc.model} {self.sc.formation} '
                               f'({self.sc.controller}), {self.mode}')

    def _apply_parameters(self, _params):
        integral = self.ctrl.integral
        self.sc = parameters.current(self)
        self.ctrl = Controller(self.sc)
        self.ctrl.integral = integral

    def _reject(self, what):
        self.rejected += 1
        self.get_logger().warn(f'dropped {what} (total dropped: {self.rejected})',
                               throttle_duration_sec=2.0)

    def _on_flow(self, msg):
        flow = complex(msg.vector.x, msg.vector.y)
        if not (math.isfinite(flow.real) and math.isfinite(flow.imag)):
            return self._reject('a non-finite flow')
        self.flow = flow

    def _on_odom(self, msg):
        X = itf.state_from_odom(msg, self.flow, self.sc.model)
        if not np.all(np.isfinite(X)):
            return self._reject('a non-finite odometry')
        ns = itf.stamp_ns(msg.header.stamp)
        self.X, self.odom_ns = X[:, None], ns
        view = self.ctrl.view(self.X, self.F_held)
        row = (view.r[0], view.phase[0], view.rate[0], view.speed[0])
        self._store(self.k, ns, row)
        self.speed_dot = view.speed_dot[0]
        self.state_pub.publish(itf.state_msg(self.k, ns, X, row))
        self._lockstep(ns)

    def _on_state(self, j, msg):
        values = np.asarray(msg.position, float)
        if len(values) != len(itf.STATE_FIELDS) or not np.all(np.isfinite(values)):
            return self._reject(f'a malformed formation_state of vehicle {j}')
        x, y, _, _, phase, rate, speed = values
        ns = itf.stamp_ns(msg.header.stamp)
        self._store(j, ns, (complex(x, y), phase, rate, speed))
        self._lockstep(ns)

    def _store(self, j, ns, row):
        i = j - 1
        self.r[i] = row[0]
        self.table[:, i] = row[1:]
        self.stamp[i] = ns

    def _lockstep(self, ns):
        if (self.mode == 'lockstep' and ns == self.odom_ns and self.commanded_ns != ns
                and np.all(self.stamp == ns)):
            self._command(ns, np.ones(self.stamp.size, bool))

    def _on_timer(self):
        if self.X is not None:
            self._command(self.get_clock().now().nanoseconds, self.stamp >= 0)

    def _command(self, ns, live):
        own = int(np.count_nonzero(live[:self.k - 1]))
        speed_dot = np.zeros(np.count_nonzero(live))
        speed_dot[own] = self.speed_dot
        phase, rate, speed = self.table[:, live]
        view = laws.View(self.r[live], phase, rate, speed, speed_dot)
        U = self.ctrl.command(view, self.X, [own])
        self.F_held = U[1].copy()
        self.commanded_ns = ns
        self.cmd_pub.publish(itf.cmd_msg(self.k, ns, U[:, 0], self.sc.model))


def vehicle_id_from_args(context):
    """Read ``vehicle_id`` from the command line / parameter file before naming the node."""
    probe = Node('vehicle', context=context, start_parameter_services=False,
                 enable_rosout=False)
    try:
        probe.declare_parameter('vehicle_id', 0)
        return probe.get_parameter('vehicle_id').value
    finally:
        probe.destroy_node()


def main(args=None):
    from formation_control.ros.runner import run

    def make(context):
        k = vehicle_id_from_args(context)
        if not isinstance(k, int) or k < 1:
            raise ScenarioError(f"parameter 'vehicle_id' = {k!r} is invalid: give the vehicle's "
                                f'id, an integer in 1..num_vehicles (-p vehicle_id:=1)')
        return VehicleNode(k, context=context)
    return run(make, args)


if __name__ == '__main__':
    sys.exit(main())
