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
publishes its own command (an aircraft also its autopilot demand on ``cmd_vel``, which its
plant flies). It knows nothing of the others but what it receives. With
``flow_source: estimated`` it hears no flow: it estimates it from its odometry and, a rigid
body, its through-water velocity (``water_velocity``); its estimate is in its diagnostics.

What it does with each input is :class:`formation_control.protocol.vehicle.Vehicle` (when it
commands and from which neighbours, the faults injected on what it hears, the law); incoming
bytes go through :mod:`formation_control.protocol.intake`: this node converts messages and
publishes. Malformed, stale or foreign messages are dropped, logged and counted; the counts are
in its ``/diagnostics`` status ``formation_control/vehicle_k/links``.
"""
import sys
import time

from diagnostic_msgs.msg import DiagnosticStatus
from formation_control.core.errors import ScenarioError
from formation_control.core.sensors import covariances
from formation_control.protocol import intake, links, lockstep, messages, names
from formation_control.protocol.node_parameters import (check_frames, check_vehicle, FRAMES,
                                                        plant_differences, VEHICLE)
from formation_control.protocol.vehicle import Vehicle
from formation_control.ros import common, interface as itf, parameters, signed, tracing
from formation_control.sim.backends import backend_of
from formation_control_msgs.msg import FormationState, VehicleCommand
from geometry_msgs.msg import TwistStamped, Vector3Stamped
from nav_msgs.msg import Odometry
from rclpy.event_handler import SubscriptionEventCallbacks
from rclpy.node import Node
from rclpy.qos_overriding_options import QoSPolicyKind
from std_msgs.msg import String

LINK_PARAMETERS = tuple(name for name in links.PARAMETERS if name != 'command_timeout')
REJECTS = ('non_finite', 'malformed', 'wrong_frame', 'stale', 'foreign_id',
           'interface_version')
LATENCIES = ('odom_to_command', 'stamp_to_command')
"""Real time, last 1000 commands: odometry handed to the node -> command sent (the node's own
latency), and odometry stamp -> command sent (adds the transport, the queue and any lag of the
plant behind the wall clock)."""


class VehicleNode(Node):
    """The controller of vehicle ``vehicle_id`` (1..N): messages in and out of a Vehicle."""

    def __init__(self, vehicle_id, **kwargs):
        super().__init__(f'vehicle_{vehicle_id}', **kwargs)
        self.k = k = vehicle_id
        self.done, self.exit_code = False, 0
        parameters.declare_node(self, {'vehicle_id': (k, VEHICLE['vehicle_id'][1]),
                                       'mode': VEHICLE['mode']})
        parameters.declare(self)
        parameters.reject_unknown(self, VEHICLE)
        sc = parameters.current(self)
        self.mode = parameters.choice(self, 'mode', parameters.MODES)
        check_vehicle(sc, k)
        link = parameters.declare_links(self, LINK_PARAMETERS, sc.num_vehicles, k)
        frames = parameters.declare_node(self, FRAMES)
        check_frames(frames, per_vehicle=False)
        self.frames = names.Frames(frames['world_frame'], frames['base_frame'])
        self.wall, self.now = common.wall_clock()
        self.born = self.now()
        self.me = Vehicle(sc, k, self.mode == 'lockstep', link, self.now, self.frames)
        self.reject = common.Rejections(self.get_logger(), REJECTS)
        self.signed = signed.of_node(self, self.reject, f'vehicle_{k}')
        common.clock_bytes(self, self.reject, self.signed)
        self.latency = common.Latencies(LATENCIES)
        self.trace = tracing.of_node(f'vehicle_{k}')
        self._create_topics(sc)
        self.add_on_set_parameters_callback(parameters.validator(self, lambda params: links.check(
            {p.name: tuple(p.value or ()) for p in params if p.name == 'cut_links'},
            sc.num_vehicles, k)))
        self.add_post_set_parameters_callback(self._apply_parameters)
        if self.mode == 'lockstep':
            self.create_timer(min(0.05, self.me.liveness_timeout / 4), self._try_command,
                              clock=self.wall)
        if self.me.faults_active:
            self.create_timer(0.002, self._deliver, clock=self.wall)
        self.create_timer(1.0, self._publish_diagnostics, clock=self.wall)
        self.get_logger().info(f'vehicle {k}/{sc.num_vehicles}: {sc.model} {sc.formation} '
                               f'({sc.controller}), {self.mode}')

    @property
    def sc(self):
        """Return the scenario this vehicle flies (its run-time parameters applied)."""
        return self.me.sc

    def _create_topics(self, sc):
        k, qos, frames = self.k, itf.state_qos_kwargs, self.frames
        publisher = self.create_publisher if self.signed is None else self.signed.publisher
        self.state_pub = publisher(FormationState, names.topic(k, 'formation_state'), **qos())
        self.cmd_pub = publisher(VehicleCommand, names.topic(k, 'cmd'), **qos())
        self.cmd_wire = itf.cmd_wire(k, sc.model, frames)
        self.cmd_vel_pub = self.last_cmd_vel = None
        if backend_of(sc).takes_demand:
            self.cmd_vel_pub = publisher(TwistStamped, names.topic(k, 'cmd_vel'), **qos())
            self.cmd_vel_wire = itf.cmd_vel_wire(k, frames)
        self.odometry = common.Decoder(intake.odometry(itf.odom_wire(
            k, frames, covariances(sc)), k, frames.world, frames.base(k)), Odometry, self.reject)
        self.odom_sub = common.raw_subscription(
            self, Odometry, names.topic(k, 'odom'), self._on_odom, self.signed,
            **qos(reader=True), **self._odom_events())
        subscribe = common.subscribe_messages
        if sc.flow_source == 'known':
            subscribe(self, Vector3Stamped, names.topic(k, 'flow'), lambda msg: self._measured(
                self.me.flow_heard(messages.stamp_ns(msg.header.stamp), complex(
                    msg.vector.x, msg.vector.y), msg.header.frame_id)), self.reject,
                qos_profile=itf.LATCHED_READER_QOS)
        if self.me.second == 'water':
            subscribe(self, TwistStamped, names.topic(k, 'water_velocity'), lambda msg: (
                self._measured(self.me.water_heard(messages.stamp_ns(msg.header.stamp), (
                    msg.twist.linear.x, msg.twist.linear.y), msg.header.frame_id))),
                self.reject, **qos(reader=True))
        subscribe(self, String, names.SCENARIO_TOPIC, self._on_scenario, self.reject,
                  qos_profile=itf.LATCHED_READER_QOS)
        for j in sc.comm_graph.neighbours(k):
            common.subscribe(self, FormationState, names.topic(j, 'formation_state'),
                             intake.formation_state(messages.StateWire.of(sc, j, frames), frames),
                             self.reject, lambda state, j=j: self._on_state(j, state),
                             self.signed)
        self.diag_pub = common.diagnostics_publisher(self)

    def _apply_parameters(self, params):
        for p in params:
            if p.name == 'cut_links':
                self.get_logger().warn(f'links cut: {self.me.cut_links(p.value or ())}')
        self.me.retune(parameters.current(self))

    def _on_scenario(self, msg):
        """Refuse to fly when the plant's latched scenario differs from this vehicle's."""
        try:
            listed = plant_differences(self.sc, msg.data)
        except ScenarioError as err:
            return self.reject('malformed', f'an unreadable plant scenario ({err})')
        if listed:
            self.get_logger().error(f"refused: this vehicle's scenario differs from the "
                                    f"plant's ({self.resolve_topic_name(names.SCENARIO_TOPIC)}): "
                                    f'{listed}')
            self.done, self.exit_code = True, 2

    def destroy_node(self):
        """Write the trace of the hot path, if asked (:mod:`formation_control.ros.tracing`)."""
        self.trace.save()
        return super().destroy_node()

    def _odom_events(self):
        """Event callbacks of the odometry reader: it adapts to a less demanding publisher."""
        if self.signed is not None:
            return {}
        return {'event_callbacks': SubscriptionEventCallbacks(
            incompatible_qos=self._odom_incompatible)}

    def _odom_incompatible(self, info):
        """
        Match an odometry publisher that offers less than the fleet's (volatile, best effort).

        A driver's ordinary odometry (the remap of docs/usage.md) is volatile, often best
        effort: the reader takes what it offers, once per policy, and says so (a sample
        published before it joined is then not resent; lockstep asks again).
        """
        kind = QoSPolicyKind(info.last_policy_kind)
        profile = itf.relaxed(self.odom_sub.qos_profile, kind)
        topic = self.odom_sub.topic_name
        if profile is None:
            self.get_logger().error(f'{topic}: a publisher offers an incompatible {kind.name} '
                                    f'policy: no odometry flows from it',
                                    throttle_duration_sec=10.0)
            return

        def resubscribe():
            self.destroy_timer(timer)
            self.destroy_subscription(self.odom_sub)
            self.odom_sub = self.create_subscription(
                Odometry, topic, self._on_odom, profile, raw=True, **self._odom_events())
        timer = self.create_timer(0.0, resubscribe, clock=self.wall)
        self.get_logger().warn(f'{topic}: a publisher offers less {kind.name} than this vehicle '
                               f'asks: the odometry reader takes {profile.durability.name} '
                               f'{profile.reliability.name} now')

    def _on_odom(self, data):
        self.odom_in = time.perf_counter_ns()
        got = self.odometry(data)
        if got is not None:
            self.trace.since('odom_in', self.k, got[0], self.odom_in)
            self._measured(self.me.odometry(*got))

    def _measured(self, got):
        """Send the state of a sampled step, answer a step asked again, or count a refusal."""
        if got is None or self._refused(got):
            return
        if got is lockstep.REPEATED:
            self.state_pub.publish(self.last_state)
            if self.me.answered:
                self.cmd_pub.publish(self.last_cmd)
                if self.cmd_vel_pub is not None:
                    self.cmd_vel_pub.publish(self.last_cmd_vel)
            return
        self.last_state = self.me.encode(got)
        if self.mode == 'realtime':                       # the plant first, the neighbours next
            self._try_command()
        self.state_pub.publish(self.last_state)
        self.trace.note('state_sent', self.k, got.stamp)
        if self.mode == 'lockstep':
            self._try_command()

    def _refused(self, got):
        if isinstance(got, intake.Rejection):
            self.reject(got.kind, got.what)
            return True
        return False

    def _deliver(self):
        for accepted in self.me.deliver():
            self._heard(accepted)

    def _on_state(self, j, state):
        self.trace.note('state_in', j, state.stamp)
        self._heard(self.me.heard(j, state))

    def _heard(self, accepted):
        if not self._refused(accepted) and accepted and self.mode == 'lockstep':
            self._try_command()

    def _try_command(self):
        start = self.trace.clock()
        due = self.me.command()
        if due is None:
            return
        ns, u, first = due
        self.trace.note('law_start', self.k, ns, at=start)
        self.trace.note('law_end', self.k, ns)
        if first:
            self.get_logger().info(f'first command, for t = {ns * 1e-9:.3f} s')
        self.last_cmd = self.cmd_wire.encode(ns, messages.cmd_values(u, self.sc.model))
        self.cmd_pub.publish(self.last_cmd)
        self.trace.note('cmd_sent', self.k, ns)
        if self.cmd_vel_pub is not None:
            self._publish_cmd_vel(ns, u)
        if self.mode == 'realtime':
            own = time.perf_counter_ns() - self.odom_in
            self.latency.add(own, self.get_clock().now().nanoseconds - ns)
            self.me.measured_delay(1e-9 * own)

    def _publish_cmd_vel(self, ns, u):
        """Publish an aircraft's autopilot demand: airspeed and turn rate, in its base frame."""
        self.last_cmd_vel = self.cmd_vel_wire.encode(ns, self.me.autopilot_demand(u))
        self.cmd_vel_pub.publish(self.last_cmd_vel)

    def _publish_diagnostics(self):
        stalled = self.me.stalled(self.now(), self.born, itf.STALL)
        if stalled == 'odometry':
            topic, matched = self._odometry_publishers()
            self.get_logger().warn(f'no odometry yet on {topic} ({matched} publishers matched)',
                                   throttle_duration_sec=5.0)
        elif isinstance(stalled, float):
            topic, matched = self._odometry_publishers()
            self.get_logger().warn(f'no odometry for {stalled:.1f} s since the command for t = '
                                   f'{self.me.odom_ns * 1e-9:.3f} s: the plant waits for '
                                   f'another vehicle or has ended, or this vehicle no longer '
                                   f'hears it ({topic}: {matched} publishers matched)',
                                   throttle_duration_sec=5.0)
        elif stalled is not None:
            self.get_logger().warn(f'step t = {self.me.odom_ns * 1e-9:.3f} s: waiting '
                                   f'{stalled[0]:.1f} s for the states of vehicles {stalled[1]}',
                                   throttle_duration_sec=5.0)
        gone, text, values = self.me.status(self.reject.counts)
        awaiting = stalled[1] if isinstance(stalled, tuple) else []
        common.publish_diagnostics(self, self.diag_pub, [common.status(
            f'formation_control/vehicle_{self.k}/links',
            DiagnosticStatus.WARN if gone else DiagnosticStatus.OK, text,
            {**values, 'awaiting': awaiting, **self.latency.summary()},
            hardware_id=f'vehicle_{self.k}')])

    def _odometry_publishers(self):
        """Return its odometry topic and the number of publishers matched to it."""
        topic = self.resolve_topic_name(names.topic(self.k, 'odom'))
        return topic, self.count_publishers(topic)


def _probe_parameter(context, name, default):
    """Read ``name`` from the command line / parameter file before naming the node(s)."""
    probe = common.probe_node('vehicle', context)
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
