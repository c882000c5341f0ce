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

- ``/formation/metrics`` (sensor_msgs/JointState, names in :data:`interface.METRIC_DOC`), every
  ``period`` seconds of the fleet's time, once it holds an odometry of every vehicle from the
  current period (lockstep: of one step; real time: sampled within one control period);
- ``/diagnostics``: one status per vehicle (stale odometry, command or formation state, saturated
  command, not converging) and one for the formation ("converged" with the time it took),
  every ``diagnostics_period`` wall seconds and whenever the formation's status changes;
- ``/formation/markers`` for RViz, every ``markers_period`` wall seconds while subscribed;
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
from formation_control.core import graphs, laws
from formation_control.core.control import Controller
from formation_control.core.models import ground_velocity, position, ROW_THETA, ROW_X, ROW_Y
from formation_control.core.scenario import resolve, RUNTIME, ScenarioError
from formation_control.protocol import intake, messages, names
from formation_control.protocol.node_parameters import MONITOR
from formation_control.ros import common, interface as itf, markers, parameters
from formation_control.sim import metrics
from geometry_msgs.msg import WrenchStamped
from nav_msgs.msg import Odometry
import numpy as np
from rcl_interfaces.msg import ParameterEvent
from rclpy.node import Node
from rclpy.parameter import parameter_value_to_python
from rclpy.qos import qos_profile_parameter_events
from rclpy.serialization import serialize_message
from sensor_msgs.msg import JointState
from std_msgs.msg import String
from visualization_msgs.msg import MarkerArray

OK, WARN, ERROR = DiagnosticStatus.OK, DiagnosticStatus.WARN, DiagnosticStatus.ERROR
PREFIX = 'formation_control/'


def _status(name, level, message, values):
    return common.status(PREFIX + name, level, message, values,
                         hardware_id=name if name.startswith('vehicle_') else '')


class MonitorNode(Node):
    """Metrics, diagnostics and markers of the fleet that publishes ``formation/scenario``."""

    def __init__(self, **kwargs):
        super().__init__('formation_monitor', **kwargs)
        self.p = parameters.declare_node(self, MONITOR)
        parameters.reject_unknown(self, MONITOR)
        self.wall, self.now = common.wall_clock()
        self.sc = None
        self.reject = common.Rejections(self.get_logger(),
                                        ('malformed', 'non_finite', 'wrong_frame'))
        self.create_subscription(String, names.SCENARIO_TOPIC, self._on_scenario, itf.LATCHED_QOS)
        self.create_subscription(ParameterEvent, '/parameter_events', self._on_parameter_event,
                                 qos_profile_parameter_events)
        self.vehicle_nodes = {}
        self.scenario_topic = self.resolve_topic_name(names.SCENARIO_TOPIC)
        self.diag_pub = common.diagnostics_publisher(self)
        self.live = None
        if self.p['foxglove_port']:
            from formation_control.ros.live import LiveView
            self.live = LiveView(self, self.p['foxglove_host'], self.p['foxglove_port'],
                                 self.p['world_frame'])
            self.get_logger().info(f"Foxglove live view on ws://{self.p['foxglove_host']}:"
                                   f'{self.live.port}')
        self.create_timer(self.p['diagnostics_period'], self.publish_diagnostics,
                          clock=self.wall)
        self.get_logger().info(f"waiting for the fleet's scenario on {self.scenario_topic}")

    def _on_scenario(self, msg):
        try:
            sc = resolve(json.loads(msg.data))
        except (ValueError, ScenarioError) as err:
            return self.reject('malformed', f'a scenario that does not parse ({err})')
        if self.sc is None:
            self._setup(sc)
        elif sc != self.sc:
            self.get_logger().warn('a different scenario was announced; restart the monitor to '
                                   'follow it', throttle_duration_sec=10.0)

    def _on_parameter_event(self, msg):
        """Take a run-time parameter once every vehicle of the fleet holds the same value."""
        k = self.vehicle_nodes.get(msg.node)
        changed = [p for p in msg.changed_parameters if p.name in RUNTIME]
        if k is None or not changed:
            return
        for p in changed:
            self.runtime[p.name][k - 1] = _hashable(parameter_value_to_python(p.value))
        agreed = {name: values[0] for name, values in self.runtime.items()
                  if len(set(values)) == 1 and values[0] != _hashable(getattr(self.sc, name))}
        if not agreed:
            return
        try:
            self.sc = resolve({**self.sc.to_dict(), **{
                name: list(v) if isinstance(v, tuple) else v for name, v in agreed.items()}})
        except ScenarioError as err:
            return self.get_logger().warn(f'the fleet took {agreed}, which is invalid: {err}')
        self.ctrl = Controller(self.sc)
        self.get_logger().info(f'every vehicle took {agreed}: the metrics follow')

    def _setup(self, sc):
        self.sc = sc
        n = sc.num_vehicles
        prefix = self.get_namespace().rstrip('/')
        self.vehicle_nodes = {f'{prefix}/vehicle_{k}': k for k in range(1, n + 1)}
        self.runtime = {name: [_hashable(getattr(sc, name))] * n for name in RUNTIME}
        self.ctrl = Controller(sc)
        self.X = np.full((6, n), np.nan)
        self.U = np.zeros((2, n))
        self.odom_ns = np.full(n, -1, np.int64)
        self.heard = {stream: np.full(n, np.nan) for stream in ('odom', 'cmd', 'state')}
        self.started = self.now()
        self.t0_ns = self.next_ns = None
        self.t = 0.0
        self.trails = np.full((self.p['trail_length'], n), np.nan, complex)
        self.samples = 0
        self.since = None
        self.vehicle_ok = np.zeros(n, bool)
        self.saturated = np.zeros(n, bool)
        self.values = {}
        self.graph = sc.comm_graph
        self.hearing = np.ones((n, n), bool)
        for k in range(1, n + 1):
            self._subscribe(Odometry, k, 'odom', intake.odometry(
                itf.odom_wire(k), k, self.p['world_frame']), self._on_odom)
            self._subscribe(WrenchStamped, k, 'cmd', intake.command(itf.cmd_wire(k), k),
                            self._on_cmd)
            self._subscribe(JointState, k, 'formation_state', intake.formation_state(
                messages.StateWire.of(sc, k)), self._on_state)
        self.metrics_pub = self.create_publisher(JointState, names.METRICS_TOPIC, itf.STREAM_QOS)
        self.markers_pub = self.create_publisher(MarkerArray, names.MARKERS_TOPIC, itf.STREAM_QOS)
        self.create_timer(self.p['markers_period'], self.publish_markers, clock=self.wall)
        self.get_logger().info(f'monitoring {n} x {sc.model}, {sc.formation}')

    def _heard(self, stream, k):
        self.heard[stream][k - 1] = self.now()

    def _subscribe(self, msg_type, k, name, rule, take):
        common.subscribe(self, msg_type, names.topic(k, name), rule, self.reject,
                         lambda got: take(k, got))

    def _on_state(self, k, state):
        """Note a vehicle's formation state and which of its graph neighbours it hears."""
        for j, hears in state.hears.items():
            self.hearing[k - 1, j - 1] = hears
        self._heard('state', k)

    def live_graph(self):
        """Return the live vehicles (N,) bool and the live links (L, 2), 0-based."""
        fresh = self.now() - self.heard['state'] <= self.p['stale_timeout']
        return fresh, graphs.live_edges(self.graph, self.hearing, fresh)

    def _on_cmd(self, k, got):
        u = np.array(messages.input_from_cmd_values(got[1], self.sc.model))
        if not np.all(np.isfinite(u)):
            return self.reject('non_finite', f'a non-finite command of vehicle {k}')
        self.U[:, k - 1] = u
        self._heard('cmd', k)

    def _on_odom(self, k, got):
        ns, values = got
        flow = complex(self.ctrl.plant.flow(self.t, values[0], values[1]))
        x = messages.state_from_odom_values(values, flow, self.sc.model)
        if not np.all(np.isfinite(x)):
            return self.reject('non_finite', f'a non-finite odometry of vehicle {k}')
        self.X[:, k - 1] = x
        self.odom_ns[k - 1] = ns
        self._heard('odom', k)
        oldest = self.odom_ns.min()
        if oldest >= 0 and (self.next_ns is None or oldest >= self.next_ns):
            self._sample(ns)

    def _sample(self, ns):
        if self.t0_ns is None:
            self.t0_ns = ns
        self.next_ns = ns + int(round(self.p['period'] * 1e9))
        self.t = (ns - self.t0_ns) * 1e-9
        snap = metrics.snapshot(self.ctrl, self.X, self.U, self.t)
        fresh, live = self.live_graph()
        self.values = {**snap.values(), 'live_links': float(len(live)),
                       'algebraic_connectivity': graphs.connectivity(fresh, live)}
        self.metrics_pub.publish(itf.metrics_msg(ns, self.values, self.p['world_frame']))
        if self.live is not None:
            self.live.log_metrics(ns, self.values)
        self.shown = ns, self.t, self.X.copy(), self.U.copy()
        self.trails[self.samples % len(self.trails)] = position(self.X)
        self.samples += 1
        flow = self.ctrl.plant.flow(self.t, self.X[ROW_X], self.X[ROW_Y])
        self.vehicle_ok = metrics.vehicles_converged(self.ctrl,
                                                     self.ctrl.view(self.X, self.U[1], flow))
        self.saturated = self.ctrl.saturated(self.U)
        was = self.since is not None
        if not metrics.converged(self.sc, snap):
            self.since = None
        elif not was:
            self.since = self.t
        if was != (self.since is not None):
            self.publish_diagnostics()

    def _vehicle_status(self, i, now):
        reasons, level = [], OK
        ages = {s: now - (h[i] if np.isfinite(h[i]) else self.started)
                for s, h in self.heard.items()}
        stale = self.p['stale_timeout']
        if ages['odom'] > stale:
            reasons.append(f"stale odom ({ages['odom']:.1f} s)")
            level = ERROR
        for stream, what in (('cmd', 'cmd'), ('state', 'formation_state')):
            if ages[stream] > stale:
                reasons.append(f'stale {what} ({ages[stream]:.1f} s)')
        if self.saturated[i]:
            reasons.append('command saturated')
        late = self.t > self.p['converge_within'] and self.since is None
        if late and not self.vehicle_ok[i]:
            reasons.append(f'not converging after {self.t:.1f} s')
        if reasons and level == OK:
            level = WARN
        values = {f'{s}_age': f'{a:.3f}' for s, a in ages.items()}
        if self.ctrl.rigid:
            values.update(thrust=self.U[0, i], steering_force=self.U[1, i])
        else:
            values['turn_command'] = self.U[1, i]
        values['converged'] = bool(self.vehicle_ok[i])
        return _status(f'vehicle_{i + 1}', level, '; '.join(reasons) or 'ok', values)

    def _formation_status(self):
        values = {'time': f'{self.t:.3f}', 'rejected_messages': self.reject.total}
        values.update({k: f'{v:.6g}' for k, v in self.values.items()})
        if self.since is not None:
            values['convergence_time'] = f'{self.since:.3f}'
            return _status('formation', OK, f'converged in {self.since:.2f} s', values)
        if self.t > self.p['converge_within']:
            return _status('formation', WARN, f'not converged after {self.t:.1f} s', values)
        return _status('formation', OK, 'converging', values)

    def publish_diagnostics(self):
        """Publish the formation's status and every vehicle's on ``/diagnostics``."""
        if self.sc is None:
            statuses = [_status('formation', WARN, f'waiting for {self.scenario_topic}', {})]
        else:
            now = self.now()
            statuses = [self._formation_status()] + [
                self._vehicle_status(i, now) for i in range(self.sc.num_vehicles)]
        msg = common.publish_diagnostics(self, self.diag_pub, statuses)
        if self.live is not None:
            self.live.log_diagnostics(messages.stamp_ns(msg.header.stamp), serialize_message(msg))

    def _picture(self):
        """Return the last sample's state, stamp, trails, velocities, centres and c0."""
        ns, t, X, U = self.shown
        sc = self.sc
        count = min(self.samples, len(self.trails))
        order = (np.arange(count) + self.samples - count) % len(self.trails)
        ground = None
        flow = self.ctrl.plant.flow(t, X[ROW_X], X[ROW_Y])
        if np.any(flow != 0):
            ground = ground_velocity(X, flow)
        centres = target = None
        if isinstance(self.ctrl.formation, laws.Circular):
            centres = self.ctrl.formation.centres(self.ctrl.view(X, U[1], flow))
            target = sc.c0_c if sc.informed else None
        return X, ns, self.trails[order].T, ground, centres, target

    def publish_markers(self):
        """Publish the markers and the live view's scene, to whichever has a subscriber."""
        rviz = self.markers_pub.get_subscription_count() > 0
        live = self.live is not None and self.live.wants_scene()
        if self.samples == 0 or not (rviz or live):
            return
        X, ns, trails, ground, centres, target = self._picture()
        edges = self.live_graph()[1]
        if rviz:
            msg = markers.fleet_markers(ns, X, ground, trails, centres, target)
            msg.markers.append(markers.link_marker(ns, position(X), edges))
            msg.markers.append(markers.metrics_marker(ns, self.values, position(X)))
            for marker in msg.markers:
                marker.header.frame_id = self.p['world_frame']
            self.markers_pub.publish(msg)
        if live:
            self.live.log_scene(ns, position(X), X[ROW_THETA], ground, trails, edges, centres,
                                target)

    def destroy_node(self):
        if self.live is not None:
            self.live.close()
            self.live = None
        return super().destroy_node()


def _hashable(value):
    return tuple(value) if isinstance(value, (list, tuple)) else value


def main(args=None):
    from formation_control.ros.runner import run
    return run(lambda context: MonitorNode(context=context), args)


if __name__ == '__main__':
    sys.exit(main())
