"""
``vehicle``: one vehicle's decentralised controller (a node per vehicle).

It hears its own odometry and flow, publishes its ``formation_state`` (pose, heading, yaw
rate and the phase values of the law), hears the formation states of its neighbours, and
publishes its own command. It knows nothing of the others but what it receives.

Lockstep: the command for step t is computed once the vehicle holds its own odometry and the
state stamped t of every live neighbour. Real time: it is computed and sent as soon as an
odometry arrives, from the latest states of the live neighbours, and the state follows. A
neighbour silent for ``neighbor_timeout`` wall seconds leaves the formation sums (N, the
averages, the projector P) until it speaks again; one never heard is waited for (start-up,
processes in any order). Faults can be injected on what it hears
(:mod:`links`). Malformed, stale or foreign messages are dropped, logged and counted; the counts
are in its ``/diagnostics`` status ``formation_control/vehicle_k/links``.
"""
import collections
import heapq
import itertools
import math
import sys
import time

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
import numpy as np
from rcl_interfaces.msg import ParameterDescriptor
from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from rclpy.serialization import deserialize_message
from geometry_msgs.msg import Vector3Stamped, WrenchStamped
from nav_msgs.msg import Odometry
from sensor_msgs.msg import JointState

from formation_control.core import laws, links
from formation_control.core.control import Controller
from formation_control.core.scenario import ScenarioError
from formation_control.ros import interface as itf
from formation_control.ros import parameters

LINK_PARAMETERS = ('neighbor_timeout', 'drop_probability', 'delay', 'delay_jitter', 'comm_range',
                   'fault_links', 'fault_seed')
REJECTS = ('non_finite', 'malformed', 'wrong_frame', 'stale', 'foreign_id')
LATENCIES = ('odom_to_command', 'stamp_to_command')
"""Real time, last 1000 commands: odometry handed to the node -> command sent (the node's own
latency), and odometry stamp -> command sent (adds the transport, the queue and any lag of the
plant behind the wall clock)."""


class VehicleNode(Node):
    """The controller of vehicle ``vehicle_id`` (1..N)."""

    def __init__(self, vehicle_id, **kwargs):
        super().__init__(f'vehicle_{vehicle_id}', **kwargs)
        self.k = vehicle_id
        self.declare_parameter('vehicle_id', vehicle_id, ParameterDescriptor(
            description='this vehicle\'s id k, 1..num_vehicles', read_only=True))
        self.declare_parameter('mode', 'lockstep', ParameterDescriptor(
            description='lockstep (waits for every live neighbour at each step) | '
                        'realtime (commands on each odometry from the latest states)',
            read_only=True))
        parameters.declare(self)
        parameters.reject_unknown(self, ('vehicle_id', 'vehicle_ids', 'mode', *LINK_PARAMETERS))
        self.sc = parameters.current(self)
        self.mode = parameters.choice(self, 'mode', parameters.MODES)
        if not 1 <= vehicle_id <= self.sc.num_vehicles:
            raise ScenarioError(f"parameter 'vehicle_id' = {vehicle_id} is invalid: must lie in "
                                f'1..num_vehicles = {self.sc.num_vehicles}')
        link = parameters.declare_links(self, LINK_PARAMETERS, self.sc.num_vehicles, vehicle_id)
        self.liveness = links.Liveness(self.sc.num_vehicles, link.pop('neighbor_timeout'))
        self.faults = links.Faults(**link, vehicle_id=vehicle_id)
        self.wall = Clock(clock_type=ClockType.STEADY_TIME)
        self.born = self._now()
        self.counts = dict.fromkeys(REJECTS + ('dropped', 'out_of_range', 'saturated'), 0)
        self.queue = []
        self.arrivals = itertools.count()
        self.step_since = math.inf if self.mode == 'lockstep' else -math.inf
        self.latency = collections.deque(maxlen=1000)
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
        self.wires = [itf.StateWire(j) for j in range(1, n + 1)]
        self.state_pub = self.create_publisher(JointState, itf.topic(self.k, 'formation_state'),
                                               **itf.state_qos_kwargs())
        self.cmd_pub = self.create_publisher(WrenchStamped, itf.topic(self.k, 'cmd'),
                                             **itf.state_qos_kwargs())
        self.create_subscription(Odometry, itf.topic(self.k, 'odom'), self._on_odom,
                                 **itf.state_qos_kwargs())
        self.create_subscription(Vector3Stamped, itf.topic(self.k, 'flow'), self._on_flow,
                                 itf.LATCHED_QOS)
        for j in range(1, n + 1):
            if j != self.k:
                self.create_subscription(JointState, itf.topic(j, 'formation_state'),
                                         lambda data, j=j: self._on_state(j, data), raw=True,
                                         **itf.state_qos_kwargs())
        self.add_on_set_parameters_callback(parameters.validator(self))
        self.add_post_set_parameters_callback(self._apply_parameters)
        if self.mode == 'lockstep':
            self.create_timer(min(0.05, self.liveness.timeout / 4), self._on_watchdog,
                              clock=self.wall)
        if self.faults.active:
            self.create_timer(0.002, self._deliver, clock=self.wall)
        self.diag_pub = self.create_publisher(DiagnosticArray, itf.DIAGNOSTICS_TOPIC, itf.STREAM_QOS)
        self.create_timer(1.0, self._publish_diagnostics, clock=self.wall)
        self.get_logger().info(f'vehicle {self.k}/{n}: {self.sc.model} {self.sc.formation} '
                               f'({self.sc.controller}), {self.mode}')

    def _apply_parameters(self, _params):
        integral = self.ctrl.integral
        self.sc = parameters.current(self)
        self.ctrl = Controller(self.sc)
        self.ctrl.integral = integral

    def _now(self):
        return self.wall.now().nanoseconds * 1e-9

    def _reject(self, kind, what):
        self.counts[kind] += 1
        total = sum(self.counts[k] for k in REJECTS)
        self.get_logger().warn(f'dropped {what} ({kind}; total dropped: {total})',
                               throttle_duration_sec=2.0)

    def _on_flow(self, msg):
        flow = complex(msg.vector.x, msg.vector.y)
        if not (math.isfinite(flow.real) and math.isfinite(flow.imag)):
            return self._reject('non_finite', 'a non-finite flow')
        if msg.header.frame_id != itf.MAP_FRAME:
            return self._reject('wrong_frame', f'a flow in frame {msg.header.frame_id!r}')
        self.flow = flow

    def _on_odom(self, msg):
        self.odom_in = time.perf_counter_ns()
        if (msg.header.frame_id, msg.child_frame_id) != (itf.MAP_FRAME, itf.base_link(self.k)):
            return self._reject('wrong_frame', f'an odometry in frames {msg.header.frame_id!r}'
                                f' -> {msg.child_frame_id!r}')
        X = itf.state_from_odom(msg, self.flow, self.sc.model)
        if not np.all(np.isfinite(X)):
            return self._reject('non_finite', 'a non-finite odometry')
        ns = itf.stamp_ns(msg.header.stamp)
        if ns < self.odom_ns:
            return self._reject('stale', f'an odometry stamped {ns * 1e-9:.3f} s, older than '
                                f'the last one')
        if self.mode == 'lockstep':
            if ns == self.odom_ns:                        # the plant asks again: same answers
                return self._answer_again()
            self.step_since = self._now()
        self.X, self.odom_ns = X[:, None], ns
        view = self.ctrl.view(self.X, self.F_held)
        row = (view.r[0], view.phase[0], view.rate[0], view.speed[0])
        self._store(self.k, ns, row)
        self.speed_dot = view.speed_dot[0]
        self.last_state = self.wires[self.k - 1].encode(ns, itf.state_values(X, row))
        if self.mode == 'realtime':                       # the plant first, the neighbours next
            self._command(ns, self._live() & (self.stamp >= 0))
        self.state_pub.publish(self.last_state)
        self._lockstep(ns)

    def _answer_again(self):
        self.state_pub.publish(self.last_state)
        if self.commanded_ns == self.odom_ns:
            self.cmd_pub.publish(self.last_cmd)

    def _on_state(self, j, data):
        """A neighbour's formation_state, as bytes: read in place when in the canonical layout."""
        got = self.wires[j - 1].decode(data) or self._checked_state(j, data)
        if got is None:
            return
        ns, values = got
        if not all(map(math.isfinite, values)):
            return self._reject('non_finite', f'a non-finite formation_state of vehicle {j}')
        if self.faults.out_of_range(j, self.r[self.k - 1], complex(values[0], values[1])):
            self.counts['out_of_range'] += 1
            return
        delay = self.faults.admit(j)
        if delay is None:
            self.counts['dropped'] += 1
        elif delay > 0:
            heapq.heappush(self.queue, (self._now() + delay, next(self.arrivals), j, ns, values))
        else:
            self._accept(j, ns, values)

    def _checked_state(self, j, data):
        """(stamp, values) of a formation_state in another layout, or None once rejected."""
        try:
            msg = deserialize_message(data, JointState)
        except Exception:
            return self._reject('malformed', f'undecodable formation_state bytes of vehicle {j}')
        if len(msg.position) != len(itf.STATE_FIELDS) or list(msg.name) != list(itf.STATE_FIELDS):
            return self._reject('malformed', f'a malformed formation_state of vehicle {j}')
        if msg.header.frame_id != itf.base_link(j):
            kind = 'foreign_id' if msg.header.frame_id.endswith('/base_link') else 'wrong_frame'
            return self._reject(kind, f'a formation_state on vehicle {j}\'s topic from '
                                f'{msg.header.frame_id!r}')
        return itf.stamp_ns(msg.header.stamp), tuple(msg.position)

    def _deliver(self):
        now = self._now()
        while self.queue and self.queue[0][0] <= now:
            _, _, j, ns, values = heapq.heappop(self.queue)
            self._accept(j, ns, values)

    def _accept(self, j, ns, values):
        if ns < self.stamp[j - 1]:
            return self._reject('stale', f'a formation_state of vehicle {j} stamped '
                                f'{ns * 1e-9:.3f} s, older than the last one')
        x, y, _, _, phase, rate, speed = values
        self.liveness.heard(j - 1, self._now())
        self._store(j, ns, (complex(x, y), phase, rate, speed))
        self._lockstep(ns)

    def _store(self, j, ns, row):
        i = j - 1
        self.r[i] = row[0]
        self.table[:, i] = row[1:]
        self.stamp[i] = ns

    def _step(self):
        """(since, answered) of the current step for :class:`links.Liveness`."""
        return self.step_since, self.stamp == self.odom_ns

    def _live(self):
        """Neighbours in the formation sums, and the vehicle itself."""
        live = self.liveness.alive(self._now(), *self._step())
        live[self.k - 1] = True
        return live

    def _lockstep(self, ns):
        if self.mode != 'lockstep' or ns != self.odom_ns or self.commanded_ns == ns:
            return
        waiting = ~self.liveness.gone(self._now(), *self._step())
        waiting[self.k - 1] = True
        if np.all(self.stamp[waiting] == ns):
            self._command(ns, self.stamp == ns)

    def _on_watchdog(self):
        if self.odom_ns >= 0:
            self._lockstep(self.odom_ns)

    def _command(self, ns, live):
        own = int(np.count_nonzero(live[:self.k - 1]))
        speed_dot = np.zeros(np.count_nonzero(live))
        speed_dot[own] = self.speed_dot
        phase, rate, speed = self.table[:, live]
        view = laws.View(self.r[live], phase, rate, speed, speed_dot)
        U = self.ctrl.command(view, self.X, [own], members=live)
        self.counts['saturated'] += int(self.ctrl.saturated(U)[0])
        self.F_held = U[1].copy()
        if self.commanded_ns < 0:
            self.get_logger().info(f'first command, for t = {ns * 1e-9:.3f} s')
        self.commanded_ns = ns
        self.last_cmd = itf.cmd_msg(self.k, ns, U[:, 0], self.sc.model)
        self.cmd_pub.publish(self.last_cmd)
        if self.mode == 'realtime':
            self.latency.append((time.perf_counter_ns() - self.odom_in,
                                 self.get_clock().now().nanoseconds - ns))

    def _report_waiting(self, now):
        """Say what a lockstep vehicle has waited for more than itf.STALL seconds."""
        if self.mode != 'lockstep':
            return
        if self.odom_ns < 0 and now - self.born > itf.STALL:
            topic = itf.topic(self.k, 'odom')
            self.get_logger().warn(f'no odometry yet on {topic} ({self.count_publishers(topic)} '
                                   f'publishers matched)', throttle_duration_sec=5.0)
        elif self.odom_ns >= 0 and self.commanded_ns != self.odom_ns and \
                now - self.step_since > itf.STALL:
            waiting = ~self.liveness.gone(now, *self._step()) & (self.stamp != self.odom_ns)
            self.get_logger().warn(
                f'step t = {self.odom_ns * 1e-9:.3f} s: waiting {now - self.step_since:.1f} s '
                f'for the states of vehicles {[int(j) + 1 for j in np.flatnonzero(waiting)]}',
                throttle_duration_sec=5.0)

    def _publish_diagnostics(self):
        now = self._now()
        self._report_waiting(now)
        gone = [j + 1 for j in np.flatnonzero(self.liveness.gone(now, *self._step()))
                if j + 1 != self.k]
        live = int(np.count_nonzero(self.liveness.alive(now, *self._step())))
        values = {'live_neighbours': live, 'gone_neighbours': gone, **self.counts}
        if self.latency:
            for name, ms in zip(LATENCIES, 1e-6 * np.array(self.latency).T):
                values.update({f'{name}_ms_p50': f'{np.median(ms):.3f}',
                               f'{name}_ms_p99': f'{np.percentile(ms, 99):.3f}'})
        level = DiagnosticStatus.WARN if gone else DiagnosticStatus.OK
        text = f'neighbours {gone} silent' if gone else f'{live} neighbours live'
        status = DiagnosticStatus(
            level=level, name=f'formation_control/vehicle_{self.k}/links', message=text,
            hardware_id=f'vehicle_{self.k}',
            values=[KeyValue(key=k, value=str(v)) for k, v in values.items()])
        msg = DiagnosticArray(status=[status])
        msg.header.stamp = self.get_clock().now().to_msg()
        self.diag_pub.publish(msg)


def _probe_parameter(context, name, default):
    """Read ``name`` from the command line / parameter file before naming the node(s)."""
    probe = Node('vehicle', context=context, start_parameter_services=False,
                 enable_rosout=False)
    try:
        probe.declare_parameter(name, default)
        return probe.get_parameter(name).value
    finally:
        probe.destroy_node()


def main(args=None):
    """``vehicle``: one vehicle node, ``-p vehicle_id:=k``."""
    from formation_control.ros.runner import run

    def make(context):
        k = _probe_parameter(context, 'vehicle_id', 0)
        if not isinstance(k, int) or k < 1:
            raise ScenarioError(f"parameter 'vehicle_id' = {k!r} is invalid: give the vehicle's "
                                f'id, an integer in 1..num_vehicles (-p vehicle_id:=1)')
        return VehicleNode(k, context=context)
    return run(make, args)


def main_many(args=None):
    """``vehicles``: several vehicle nodes in one process, ``-p vehicle_ids:=[1, 2, 3]``."""
    from formation_control.ros.runner import run

    def make(context):
        ids = list(_probe_parameter(context, 'vehicle_ids', [0]))
        if not ids or min(ids) < 1 or len(set(ids)) != len(ids):
            raise ScenarioError(f"parameter 'vehicle_ids' = {ids!r} is invalid: give distinct "
                                f'vehicle ids in 1..num_vehicles (-p vehicle_ids:=[1, 2])')
        return [VehicleNode(k, context=context) for k in ids]
    return run(make, args)


if __name__ == '__main__':
    sys.exit(main())
