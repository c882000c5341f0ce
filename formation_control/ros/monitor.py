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
``monitor``: watches a running fleet and says how it is doing.

It learns the scenario from the plant's latched ``/formation/scenario``, hears every vehicle's
odometry, command and formation state, and publishes

- ``/formation/metrics`` (formation_control_msgs/FormationMetrics: the metrics of
  :data:`~formation_control.protocol.messages.METRIC_DOC` and the convergence latch), every
  ``period`` seconds of the fleet's time, once it holds an odometry of every vehicle from the
  current period (lockstep: of one step; real time: sampled within one control period);
- ``/diagnostics``: one status per vehicle (stale odometry, command or formation state, saturated
  command, not converging) and one for the formation ("converged" with the time it took),
  every ``diagnostics_period`` wall seconds and whenever the formation's status changes;
- ``/formation/markers`` for RViz, every ``markers_period`` wall seconds while subscribed;
- the fleet's frames (REP-105, :mod:`formation_control.ros.tf`): ``map`` to ``world_frame`` on
  the latched ``/tf_static`` (when they differ), each vehicle's ``base_frame`` in the world
  frame on ``/tf``, at the markers' pose and period while subscribed;
- with ``foxglove_port``, a Foxglove live view of the same (:mod:`formation_control.ros.live`):
  the scene every ``markers_period`` while a client subscribes, every metrics sample, every
  ``/diagnostics``.

Times in the reports count from the first step the monitor heard. Every name is relative (the
monitor watches the fleet of its namespace). It follows run-time gain changes: when every
vehicle of its namespace has announced the same new value of a run-time parameter on
``/parameter_events`` (``formation-control set``), its scenario takes it.
"""
import json
import sys

from diagnostic_msgs.msg import DiagnosticStatus
from formation_control.core.errors import ScenarioError
from formation_control.core.scenario import resolve
from formation_control.protocol import intake, messages, names
from formation_control.protocol.node_parameters import MONITOR
from formation_control.protocol.watch import WARN, Watch
from formation_control.ros import common, interface as itf, markers, parameters
from formation_control.ros.tf import FleetFrames
from formation_control.view import picture
from formation_control_msgs.msg import FormationMetrics, FormationState, VehicleCommand
from nav_msgs.msg import Odometry
import numpy as np
from rcl_interfaces.msg import ParameterEvent
from rclpy.node import Node
from rclpy.parameter import parameter_value_to_python
from rclpy.qos import qos_profile_parameter_events
from rclpy.serialization import serialize_message
from std_msgs.msg import String
from visualization_msgs.msg import MarkerArray

LEVELS = (DiagnosticStatus.OK, DiagnosticStatus.WARN, DiagnosticStatus.ERROR)
"""The DiagnosticStatus level of each level of :mod:`formation_control.protocol.watch`."""
PREFIX = 'formation_control/'


def _status(name, level, message, values):
    return common.status(PREFIX + name, LEVELS[level], message, values,
                         hardware_id=name if name.startswith('vehicle_') else '')


class MonitorNode(Node):
    """Metrics, diagnostics and markers of the fleet that publishes ``formation/scenario``."""

    def __init__(self, **kwargs):
        super().__init__('formation_monitor', **kwargs)
        self.p = parameters.declare_node(self, MONITOR)
        parameters.reject_unknown(self, MONITOR)
        self.wall, self.now = common.wall_clock()
        self.watch = None
        self.reject = common.Rejections(self.get_logger(),
                                        ('malformed', 'non_finite', 'wrong_frame',
                                         'foreign_id', 'wrong_kind', 'interface_version',
                                         'live_client'))
        common.clock_bytes(self, self.reject)
        common.subscribe_messages(self, String, names.SCENARIO_TOPIC, self._on_scenario,
                                  self.reject, qos_profile=itf.LATCHED_READER_QOS)
        common.subscribe_messages(self, ParameterEvent, '/parameter_events',
                                  self._on_parameter_event, self.reject,
                                  qos_profile=qos_profile_parameter_events)
        self.scenario_topic = self.resolve_topic_name(names.SCENARIO_TOPIC)
        self.diag_pub = common.diagnostics_publisher(self)
        self.frames = FleetFrames(self, self.p['world_frame'], self.p['base_frame'])
        self.live = None
        if self.p['foxglove_port']:
            from formation_control.ros.live import LiveView
            self.live = LiveView(self, self.p['foxglove_host'], self.p['foxglove_port'],
                                 self.reject, self.p['world_frame'], self.p['base_frame'])
            self.get_logger().info(f"Foxglove live view on ws://{self.p['foxglove_host']}:"
                                   f'{self.live.port}')
        self.create_timer(self.p['diagnostics_period'], self.publish_diagnostics,
                          clock=self.wall)
        self.get_logger().info(f"waiting for the fleet's scenario on {self.scenario_topic}")

    @property
    def sc(self):
        """Return the fleet's scenario, with the gains it agreed on (None: not heard yet)."""
        return None if self.watch is None else self.watch.sc

    def _on_scenario(self, msg):
        try:
            sc = resolve(json.loads(msg.data))
        except (ValueError, ScenarioError) as err:
            return self.reject('malformed', f'a scenario that does not parse ({err})')
        if self.watch is None:
            self._setup(sc)
        elif sc != self.sc:
            self.get_logger().warn('a different scenario was announced; restart the monitor to '
                                   'follow it', throttle_duration_sec=10.0)

    def _on_parameter_event(self, msg):
        """Take a run-time parameter once every vehicle of the fleet holds the same value."""
        if self.watch is None:
            return
        agreed = self.watch.gains.announce(msg.node, {
            p.name: p.value for p in msg.changed_parameters}, parameter_value_to_python)
        if not agreed:
            return
        try:
            self.watch.take(agreed)
        except ScenarioError as err:
            return self.get_logger().warn(f'the fleet took {agreed}, which is invalid: {err}')
        self.get_logger().info(f'every vehicle took {agreed}: the metrics follow')

    def _setup(self, sc):
        p = self.p
        self.watch = Watch(sc, self.get_namespace(), p['period'], p['stale_timeout'],
                           p['converge_within'], p['trail_length'], self.now)
        for k in range(1, sc.num_vehicles + 1):
            self._subscribe(Odometry, k, 'odom', intake.odometry(
                itf.odom_wire(k), k, p['world_frame']), self._on_odom)
            self._subscribe(VehicleCommand, k, 'cmd', intake.command(itf.cmd_wire(k, sc.model)),
                            self._on_cmd)
            self._subscribe(FormationState, k, 'formation_state', intake.formation_state(
                messages.StateWire.of(sc, k, names.Frames(p['world_frame']))), self._on_state)
        self.metrics_pub = self.create_publisher(FormationMetrics, names.METRICS_TOPIC,
                                                 itf.STREAM_QOS)
        self.markers_pub = self.create_publisher(MarkerArray, names.MARKERS_TOPIC, itf.STREAM_QOS)
        self.create_timer(p['markers_period'], self.publish_markers, clock=self.wall)
        self.get_logger().info(f'monitoring {sc.num_vehicles} x {sc.model}, {sc.formation}')

    def _subscribe(self, msg_type, k, name, rule, take):
        common.subscribe(self, msg_type, names.topic(k, name), rule, self.reject,
                         lambda got: take(k, got))

    def _on_state(self, k, state):
        """Note a vehicle's formation state and which of its graph neighbours it hears."""
        self.watch.state(k, dict(state.hears))

    def _on_cmd(self, k, got):
        u = np.array(messages.input_from_cmd_values(got[1], self.sc.model))
        if not np.all(np.isfinite(u)):
            return self.reject('non_finite', f'a non-finite command of vehicle {k}')
        self.watch.cmd(k, u, got[0])

    def _on_odom(self, k, got):
        ns, values = got
        if not np.all(np.isfinite(values)):
            return self.reject('non_finite', f'a non-finite odometry of vehicle {k}')
        flow = complex(self.watch.flow(values[0], values[1]))
        x = messages.state_from_odom_values(values, flow, self.sc.model)
        if not np.all(np.isfinite(x)):
            return self.reject('non_finite', f'a non-finite odometry of vehicle {k}')
        if self.watch.odom(k, x, ns, messages.ground_velocity_of(values)):
            self._sample(ns)

    def _sample(self, ns):
        values, latched = self.watch.sample(ns)
        self.metrics_pub.publish(itf.metrics_msg(ns, values, self.p['world_frame'],
                                                 self.watch.t, self.watch.latch.since))
        if self.live is not None:
            self.live.log_metrics(ns, values)
        if latched:
            self.publish_diagnostics()

    def publish_diagnostics(self):
        """Publish the formation's status and every vehicle's on ``/diagnostics``."""
        if self.watch is None:
            statuses = [('formation', WARN, f'waiting for {self.scenario_topic}', {})]
        else:
            statuses = self.watch.statuses(self.reject.total)
        msg = common.publish_diagnostics(self, self.diag_pub, [_status(*s) for s in statuses])
        if self.live is not None:
            self.live.log_diagnostics(messages.stamp_ns(msg.header.stamp), serialize_message(msg))

    def publish_markers(self):
        """Publish the markers, ``/tf`` and the live view's scene, to whichever is subscribed."""
        rviz = self.markers_pub.get_subscription_count() > 0
        tf = self.frames.wanted()
        live = self.live is not None and self.live.wants_scene()
        live_markers = self.live is not None and self.live.wants_markers()
        shown = self.watch.picture() if rviz or tf or live or live_markers else None
        if shown is None:
            return
        X, ns, trails, ground, centres, target = shown
        pic = picture.of_states(ns, X, ground, trails, self.watch.live_graph()[1], centres,
                                target, self.watch.d_min)
        if rviz or live_markers:
            msg = markers.fleet_markers(pic, self.watch.values, self.p['world_frame'])
            if rviz:
                self.markers_pub.publish(msg)
            if live_markers:
                self.live.log_markers(ns, serialize_message(msg))
        if tf:
            self.frames.publish(pic)
        if live:
            self.live.log_scene(pic)

    def destroy_node(self):
        if self.live is not None:
            self.live.close()
            self.live = None
        return super().destroy_node()


def main(args=None):
    from formation_control.ros.runner import run
    return run(lambda context: MonitorNode(context=context), args)


if __name__ == '__main__':
    sys.exit(main())
