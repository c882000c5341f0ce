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
``vehicle``: one vehicle's decentralised controller (a node per vehicle).

It hears its own odometry and flow, publishes its ``formation_state`` (pose, heading, yaw
rate and the phase values of the law), hears the formation states of its neighbours, and
publishes its own command. It knows nothing of the others but what it receives. With
``flow_source: estimated`` it hears no flow: it estimates it from its odometry and, a rigid
body, its through-water velocity (``water_velocity``); its estimate is in its diagnostics.

When it commands, and from which neighbours, is :class:`neighbours.NeighbourTable`; the faults
injected on what it hears are :class:`links.Inbox`; the law is :class:`control.Controller`:
this node converts messages and publishes. Malformed, stale or foreign messages are dropped,
logged and counted; the counts are in its ``/diagnostics`` status
``formation_control/vehicle_k/links``.
"""
import json
import math
import sys
import time

from diagnostic_msgs.msg import DiagnosticStatus
from formation_control.core import scenario
from formation_control.core.models import ROW_U, ROW_V
from formation_control.core.scenario import ScenarioError
from formation_control.protocol import links, lockstep, messages, names
from formation_control.protocol.neighbours import NeighbourTable
from formation_control.protocol.node_parameters import check_frames, FRAMES, VEHICLE
from formation_control.protocol.onboard import needs_second_sensor, Onboard, Pairing
from formation_control.ros import common, interface as itf, parameters
from geometry_msgs.msg import TwistStamped, Vector3Stamped, WrenchStamped
from nav_msgs.msg import Odometry
import numpy as np
from rcl_interfaces.msg import SetParametersResult
from rclpy.node import Node
from rclpy.serialization import deserialize_message
from sensor_msgs.msg import JointState
from std_msgs.msg import String

LINK_PARAMETERS = tuple(name for name in links.PARAMETERS if name != 'command_timeout')
REJECTS = ('non_finite', 'malformed', 'wrong_frame', 'stale', 'foreign_id')
LATENCIES = ('odom_to_command', 'stamp_to_command')
"""Real time, last 1000 commands: odometry handed to the node -> command sent (the node's own
latency), and odometry stamp -> command sent (adds the transport, the queue and any lag of the
plant behind the wall clock)."""
DELAY_GAIN = 0.1
"""Real time: the weight of each new delay, odometry handed to the node -> command sent (at most
a period), in the running mean the vehicle predicts its state over, with half a period and half
an integration step (the plant applies a command from its next step), before it computes its
command. The stamp -> command latency is not used: a simulated plant that slips behind the wall
clock makes it grow without being a delay in simulated time."""


class VehicleNode(Node):
    """The controller of vehicle ``vehicle_id`` (1..N)."""

    def __init__(self, vehicle_id, **kwargs):
        super().__init__(f'vehicle_{vehicle_id}', **kwargs)
        self.k = vehicle_id
        self.done, self.exit_code = False, 0
        self._declare(vehicle_id)
        sc = self.sc = parameters.current(self)
        self.mode = parameters.choice(self, 'mode', parameters.MODES)
        if not 1 <= vehicle_id <= sc.num_vehicles:
            raise ScenarioError(f"parameter 'vehicle_id' = {vehicle_id} is invalid: must lie in "
                                f'1..num_vehicles = {sc.num_vehicles}')
        if sc.flow_consensus > 0:
            raise ScenarioError(f"parameter 'flow_consensus' = {sc.flow_consensus} is invalid "
                                f'for a vehicle node: the formation_state does not carry the '
                                f'flow estimates; use 0 (the offline simulator runs consensus)')
        link = parameters.declare_links(self, LINK_PARAMETERS, sc.num_vehicles, vehicle_id)
        frames = parameters.declare_node(self, FRAMES)
        check_frames(frames, per_vehicle=False)
        self.frames = names.Frames(frames['world_frame'], frames['base_frame'])
        self.wall, self.now = common.wall_clock()
        self.born = self.now()
        self.neighbours = sc.comm_graph.neighbours(vehicle_id)
        self.known = NeighbourTable(sc.num_vehicles, vehicle_id, link.pop('neighbor_timeout'),
                                    self.now, self.mode == 'lockstep', self.neighbours,
                                    sc.hold_prediction != 'none')
        self.inbox = links.Inbox(links.Faults(**link, vehicle_id=vehicle_id), self.now)
        self.reject = common.Rejections(self.get_logger(), REJECTS)
        self.saturated = 0
        self.latency = common.Latencies(LATENCIES)
        self.delay = 0.0
        self.tick_wait = 0.5 * sc.dt_integration if self.mode == 'realtime' else 0.0
        self.onboard = Onboard(sc)
        self.flow = sc.flow_c
        self.second = needs_second_sensor(sc)
        self.pairing = Pairing()
        self.hears = {j: () if sc.all_to_all else tuple(sc.comm_graph.neighbours(j))
                      for j in (*self.neighbours, vehicle_id)}
        self.estimates = sc.flow_source == 'estimated'
        self.wires = {j: messages.StateWire(j, hears, self.frames, self.estimates)
                      for j, hears in self.hears.items()}
        self.heard_rows = np.array([j - 1 for j in self.hears[vehicle_id]], int)
        self.my_flag = {j: len(messages.STATE_FIELDS) + hears.index(vehicle_id)
                        for j, hears in self.hears.items() if hears and j != vehicle_id}
        self._create_topics()
        self.add_on_set_parameters_callback(parameters.validator(self))
        self.add_on_set_parameters_callback(self._check_cut_links)
        self.add_post_set_parameters_callback(self._apply_parameters)
        if self.mode == 'lockstep':
            self.create_timer(min(0.05, self.known.liveness.timeout / 4), self._try_command,
                              clock=self.wall)
        if self.inbox.faults.active:
            self.create_timer(0.002, self._deliver, clock=self.wall)
        self.create_timer(1.0, self._publish_diagnostics, clock=self.wall)
        self.get_logger().info(f'vehicle {self.k}/{sc.num_vehicles}: {sc.model} {sc.formation} '
                               f'({sc.controller}), {self.mode}')

    def _declare(self, vehicle_id):
        parameters.declare_node(self, {'vehicle_id': (vehicle_id, VEHICLE['vehicle_id'][1]),
                                       'mode': VEHICLE['mode']})
        parameters.declare(self)
        parameters.reject_unknown(self, VEHICLE)

    def _create_topics(self):
        k, qos = self.k, itf.state_qos_kwargs
        self.state_pub = self.create_publisher(JointState, names.topic(k, 'formation_state'),
                                               **qos())
        self.cmd_pub = self.create_publisher(WrenchStamped, names.topic(k, 'cmd'), **qos())
        self.odom_wire, self.cmd_wire = itf.odom_wire(k, self.frames), itf.cmd_wire(k, self.frames)
        self.create_subscription(Odometry, names.topic(k, 'odom'), self._on_odom, raw=True,
                                 **qos())
        if self.sc.flow_source == 'known':
            self.create_subscription(Vector3Stamped, names.topic(k, 'flow'), self._on_flow,
                                     itf.LATCHED_QOS)
        if self.second == 'water':
            self.create_subscription(TwistStamped, names.topic(k, 'water_velocity'),
                                     self._on_water, **qos())
        self.create_subscription(String, names.SCENARIO_TOPIC, self._on_scenario, itf.LATCHED_QOS)
        for j in self.neighbours:
            self.create_subscription(JointState, names.topic(j, 'formation_state'),
                                     lambda data, j=j: self._on_state(j, data), raw=True,
                                     **qos())
        self.diag_pub = common.diagnostics_publisher(self)

    def _check_cut_links(self, params):
        try:
            links.check({p.name: tuple(p.value or ()) for p in params if p.name == 'cut_links'},
                        self.sc.num_vehicles, self.k)
        except ScenarioError as err:
            return SetParametersResult(successful=False, reason=str(err))
        return SetParametersResult(successful=True)

    def _apply_parameters(self, params):
        for p in params:
            if p.name == 'cut_links':
                self.inbox.faults.cut = set(p.value or ())
                self.get_logger().warn(f'links cut: {sorted(self.inbox.faults.cut)}')
        self.sc = parameters.current(self)
        self.onboard.retune(self.sc)

    def _on_scenario(self, msg):
        """Refuse to fly when the plant's latched scenario differs from this vehicle's."""
        try:
            theirs = scenario.resolve(json.loads(msg.data))
        except (ValueError, TypeError, ScenarioError) as err:
            return self.reject('malformed', f'an unreadable plant scenario ({err})')
        diffs = scenario.differences(self.sc, theirs)
        if diffs:
            listed = '; '.join(f'{name} = {mine!r} here, {plant!r} at the plant'
                               for name, mine, plant in diffs)
            self.get_logger().error(f"refused: this vehicle's scenario differs from the "
                                    f"plant's ({self.resolve_topic_name(names.SCENARIO_TOPIC)}): "
                                    f'{listed}')
            self.done, self.exit_code = True, 2

    def _on_flow(self, msg):
        flow = complex(msg.vector.x, msg.vector.y)
        if not (math.isfinite(flow.real) and math.isfinite(flow.imag)):
            return self.reject('non_finite', 'a non-finite flow')
        if msg.header.frame_id != self.frames.world:
            return self.reject('wrong_frame', f'a flow in frame {msg.header.frame_id!r}')
        self.flow = flow
        if self.second == 'flow':
            self._paired(self.pairing.add_other(messages.stamp_ns(msg.header.stamp), flow))

    def _on_water(self, msg):
        rel = (msg.twist.linear.x, msg.twist.linear.y)
        if not all(map(math.isfinite, rel)):
            return self.reject('non_finite', 'a non-finite water_velocity')
        if msg.header.frame_id != self.frames.base(self.k):
            return self.reject('wrong_frame', f'a water_velocity in frame '
                               f'{msg.header.frame_id!r}')
        self._paired(self.pairing.add_other(messages.stamp_ns(msg.header.stamp), rel))

    def _paired(self, pair):
        if pair is not None:
            self._on_measurement(*pair)

    def _odometry(self, data):
        """(stamp, ODOM_FIELDS) of odometry bytes, or None once rejected."""
        got = self.odom_wire.decode(data)
        if got is not None:
            return got
        try:
            msg = deserialize_message(data, Odometry)
        except Exception:
            return self.reject('malformed', 'undecodable odometry bytes')
        expected = self.frames.world, self.frames.base(self.k)
        if (msg.header.frame_id, msg.child_frame_id) != expected:
            return self.reject('wrong_frame', f'an odometry in frames {msg.header.frame_id!r}'
                               f' -> {msg.child_frame_id!r} (expected {expected[0]!r} -> '
                               f'{expected[1]!r}: world_frame, base_frame)')
        return messages.stamp_ns(msg.header.stamp), messages.odom_values_of(msg)

    def _on_odom(self, data):
        self.odom_in = time.perf_counter_ns()
        got = self._odometry(data)
        if got is None:
            return
        if not all(map(math.isfinite, got[1])):
            return self.reject('non_finite', 'a non-finite odometry')
        if self.second is None:
            return self._on_measurement(*got)
        self._paired(self.pairing.add_odometry(*got))

    def _on_measurement(self, ns, values, other=None):
        """Take the odometry of stamp ns with the second sensor's value of the same stamp."""
        flow = other if self.second == 'flow' else self.flow
        X = messages.state_from_odom_values(values, flow, self.sc.model)
        if self.second == 'water':
            X[ROW_U], X[ROW_V] = other
        if not np.all(np.isfinite(X)):
            return self.reject('non_finite', 'a non-finite odometry')
        kind = self.known.odometry(ns)
        if kind == lockstep.STALE:
            return self.reject('stale', f'an odometry stamped {ns * 1e-9:.3f} s, older than '
                               f'the last one')
        if kind == lockstep.REPEATED:
            return self._answer_again()
        row = self.onboard.observe(X, flow, messages.ground_velocity_of(values),
                                   self.delay + self.tick_wait)
        self.known.store(self.k, ns, row)
        hearing = self.known.hearing()[self.heard_rows]
        self.last_state = self.wires[self.k].encode(
            ns, messages.state_values(self.onboard.X[:, 0], row, hearing,
                                      self.onboard.flow[0] if self.estimates else None))
        if self.mode == 'realtime':                       # the plant first, the neighbours next
            self._try_command()
        self.state_pub.publish(self.last_state)
        if self.mode == 'lockstep':
            self._try_command()

    def _answer_again(self):
        """Answer a step asked again with the same state (and command, if sent)."""
        self.state_pub.publish(self.last_state)
        if self.known.commanded_ns == self.known.odom_ns:
            self.cmd_pub.publish(self.last_cmd)

    def _on_state(self, j, data):
        """Take a neighbour's formation_state bytes, read in place in the canonical layout."""
        got = self.wires[j].decode(data) or self._checked_state(j, data)
        if got is None:
            return
        ns, values = got
        if not all(map(math.isfinite, values)):
            return self.reject('non_finite', f'a non-finite formation_state of vehicle {j}')
        own = self.known.r[self.k - 1]
        if self.inbox.receive(j, got, own, complex(values[0], values[1])) == links.NOW:
            self._accept(j, ns, values)

    def _checked_state(self, j, data):
        """(stamp, values) of a formation_state in another layout, or None once rejected."""
        try:
            msg = deserialize_message(data, JointState)
        except Exception:
            return self.reject('malformed', f'undecodable formation_state bytes of vehicle {j}')
        names = self.wires[j].names
        if len(msg.position) != len(names) or tuple(msg.name) != names:
            return self.reject('malformed', f'a malformed formation_state of vehicle {j}')
        if msg.header.frame_id != self.frames.base(j):
            other = self.frames.vehicle_of(msg.header.frame_id)
            kind = 'wrong_frame' if other is None else 'foreign_id'
            return self.reject(kind, f"a formation_state on vehicle {j}'s topic from "
                               f'{msg.header.frame_id!r}')
        return messages.stamp_ns(msg.header.stamp), tuple(msg.position)

    def _deliver(self):
        for j, (ns, values) in self.inbox.due():
            self._accept(j, ns, values)

    def _accept(self, j, ns, values):
        x, y, _, _, phase, rate, speed = values[:len(messages.STATE_FIELDS)]
        flag = self.my_flag.get(j)
        hears_me = flag is None or values[flag] > 0.5
        if not self.known.hear(j, ns, (complex(x, y), phase, rate, speed), hears_me):
            return self.reject('stale', f'a formation_state of vehicle {j} stamped '
                               f'{ns * 1e-9:.3f} s, older than the last one')
        if self.mode == 'lockstep':
            self._try_command()

    def _try_command(self):
        members = self.known.ready()
        if members is not None:
            self._command(members)

    def _command(self, members):
        ns = self.known.odom_ns
        view, own = self.known.view(members, self.onboard.speed_dot)
        u, saturated = self.onboard.command(view, own, members)
        self.saturated += saturated
        if self.known.commanded_ns < 0:
            self.get_logger().info(f'first command, for t = {ns * 1e-9:.3f} s')
        self.known.commanded()
        self.last_cmd = self.cmd_wire.encode(ns, messages.cmd_values(u, self.sc.model))
        self.cmd_pub.publish(self.last_cmd)
        if self.mode == 'realtime':
            own = time.perf_counter_ns() - self.odom_in
            self.latency.add(own, self.get_clock().now().nanoseconds - ns)
            self.delay += DELAY_GAIN * (min(1e-9 * own, self.sc.dt_control) - self.delay)

    def _report_waiting(self, now):
        """Say what a lockstep vehicle has waited for more than itf.STALL seconds."""
        known = self.known
        if self.mode != 'lockstep':
            return
        if known.odom_ns < 0 and now - self.born > itf.STALL:
            topic = self.resolve_topic_name(names.topic(self.k, 'odom'))
            self.get_logger().warn(f'no odometry yet on {topic} ({self.count_publishers(topic)} '
                                   f'publishers matched)', throttle_duration_sec=5.0)
        elif known.odom_ns >= 0 and known.commanded_ns != known.odom_ns and \
                now - known.since > itf.STALL:
            waiting = (np.flatnonzero(known.waiting()) + 1).tolist()
            self.get_logger().warn(
                f'step t = {known.odom_ns * 1e-9:.3f} s: waiting {now - known.since:.1f} s '
                f'for the states of vehicles {waiting}', throttle_duration_sec=5.0)

    def _publish_diagnostics(self):
        self._report_waiting(self.now())
        gone = (np.flatnonzero(self.known.gone()) + 1).tolist()
        live = int(np.count_nonzero(self.known.live())) - 1
        delayed = self.inbox.counts[links.DELAYED]
        fhat = complex(self.onboard.flow[0])
        values = {'live_neighbours': live, 'gone_neighbours': gone, **self.reject.counts,
                  'flow_source': self.sc.flow_source, 'flow_hat_x': f'{fhat.real:.6f}',
                  'flow_hat_y': f'{fhat.imag:.6f}',
                  **self.inbox.counts, 'saturated': self.saturated,
                  'mean_delay': f'{self.inbox.delay_total / max(1, delayed):.4f}',
                  **self.latency.summary()}
        level = DiagnosticStatus.WARN if gone else DiagnosticStatus.OK
        text = f'neighbours {gone} silent' if gone else f'{live} neighbours live'
        common.publish_diagnostics(self, self.diag_pub, [common.status(
            f'formation_control/vehicle_{self.k}/links', level, text, values,
            hardware_id=f'vehicle_{self.k}')])


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
