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

"""Communication graphs through ROS: neighbours only, mutual links, lockstep == simulator."""
from formation_control.core import scenario
from formation_control.protocol import messages, names
from formation_control.ros import interface as itf
from formation_control_msgs.msg import FormationMetrics, FormationState, VehicleCommand
from nav_msgs.msg import Odometry
import numpy as np
import pytest
from rclpy.qos import QoSProfile, ReliabilityPolicy
from rosutil import CONFIG, metric_values
from runs import assert_equal_runs, offline_run
from visualization_msgs.msg import MarkerArray


def test_a_ring_vehicle_subscribes_to_its_two_neighbours_states_only(nodes):
    """What the ROS graph shows of vehicle 1 of a ring of 12: two formation-state readers."""
    nodes.vehicle(1, CONFIG / 'particle_circular_ring.yaml')
    topics = nodes.node.get_subscriber_names_and_types_by_node('vehicle_1', '/')
    states = sorted(t for t, _ in topics if t.endswith('/formation_state'))
    assert states == ['/vehicle_12/formation_state', '/vehicle_2/formation_state']
    everyone = nodes.vehicle(2, CONFIG / 'particle_circular.yaml')      # all-to-all: 15
    topics = nodes.node.get_subscriber_names_and_types_by_node('vehicle_2', '/')
    assert everyone.sc.num_vehicles == 16
    assert len([t for t, _ in topics if t.endswith('/formation_state')]) == 15


@pytest.mark.parametrize('name, overrides', [
    ('rigid_circular_ring', ['duration:=3.0']),
    ('particle_parallel_random', ['num_vehicles:=8', 'duration:=3.0']),
])
def test_lockstep_fleet_on_a_graph_equals_the_offline_simulator(nodes, tmp_path, name,
                                                                overrides):
    cfg = CONFIG / f'{name}.yaml'
    assert_equal_runs(nodes.lockstep_run(cfg, tmp_path / 'run.npz', *overrides),
                      offline_run(cfg, overrides))


def test_formation_state_says_whom_the_vehicle_hears(nodes):
    cfg = CONFIG / 'particle_circular_ring.yaml'
    states = nodes.collect(FormationState, names.topic(5, 'formation_state'), itf.STATE_QOS)
    nodes.plant(cfg)
    nodes.vehicle(5, cfg)
    assert nodes.spin_until(lambda: states, timeout=20)
    msg = states[0]
    assert (msg.vehicle_id, list(msg.neighbour_ids)) == (5, [4, 6])
    assert list(msg.hears) == [True, True]               # lockstep: neighbours awaited
    assert msg.header.frame_id == 'map' and not msg.estimates_flow


def test_a_neighbour_that_does_not_hear_the_vehicle_leaves_its_sums(nodes):
    """Vehicle 1 of a ring hears 2 and 12; 12 says it does not hear 1: 1 commands without 12."""
    cfg = CONFIG / 'particle_circular_ring.yaml'
    sc = scenario.load(cfg)
    node = nodes.vehicle(1, cfg, 'hold_prediction:=none')   # its command of the sampled state
    cmds = nodes.collect(VehicleCommand, names.topic(1, 'cmd'), itf.STATE_QOS)
    X = scenario.initial_state(sc)
    pubs = {j: nodes.node.create_publisher(FormationState, names.topic(j, 'formation_state'),
                                           itf.STATE_QOS) for j in (2, 12)}
    odom = nodes.node.create_publisher(Odometry, names.topic(1, 'odom'), itf.STATE_QOS)
    view = node.me.onboard.ctrl.view(X)

    def row(j):
        i = j - 1
        return view.r[i], view.phase[i], view.rate[i], view.speed[i]
    hears = {2: (1, 3), 12: (1, 11)}
    hearing = {2: (True, True), 12: (False, True)}
    assert nodes.spin_until(lambda: all(p.get_subscription_count() for p in pubs.values())
                            and odom.get_subscription_count(), timeout=20)
    odom.publish(itf.odom_msg(1, 0, X[:, 0], 0j))
    for j, pub in pubs.items():
        pub.publish(itf.state_msg(j, 0, X[:, j - 1], row(j), hears[j], hearing[j]))
    assert nodes.spin_until(lambda: cmds, timeout=20)
    members = np.zeros(12, bool)
    members[[0, 1]] = True
    ctrl = node.me.onboard.ctrl
    expected = ctrl.command(ctrl.view(X[:, members]), X[:, [0]], [0], members=members)
    assert cmds[0].angular_acceleration == pytest.approx(expected[1, 0], abs=1e-12)
    members[11] = True
    with_12 = ctrl.command(ctrl.view(X[:, members]), X[:, [0]], [0], members=members)
    assert abs(with_12[1, 0] - expected[1, 0]) > 1e-3


def test_monitor_reports_the_live_graph_and_draws_its_links(nodes):
    cfg = CONFIG / 'rigid_circular_ring.yaml'
    n = scenario.load(cfg).num_vehicles
    box = nodes.collect(FormationMetrics, names.METRICS_TOPIC, itf.STREAM_QOS)
    marks = nodes.collect(MarkerArray, names.MARKERS_TOPIC, itf.STREAM_QOS)
    nodes.monitor('stale_timeout:=0.5', 'markers_period:=0.05')
    nodes.plant(cfg, 'duration:=30.0')
    fleet = [nodes.vehicle(k, cfg, 'duration:=30.0', 'neighbor_timeout:=0.3') for k in
             range(1, n + 1)]

    def latest(name):
        return metric_values(box[-1])[name] if box else None
    assert nodes.spin_until(lambda: latest('live_links') == n, timeout=30)
    assert latest('algebraic_connectivity') == pytest.approx(2 - 2 * np.cos(2 * np.pi / n))
    assert nodes.spin_until(lambda: any(m.ns == 'links' and len(m.points) == 2 * n
                                        for a in marks for m in a.markers), timeout=10)
    nodes.remove(fleet[3])                     # vehicle 4 goes silent: links 3-4, 4-5 go
    assert nodes.spin_until(lambda: latest('live_links') == n - 2, timeout=30)
    assert latest('algebraic_connectivity') == pytest.approx(
        2 - 2 * np.cos(np.pi / (n - 1)), abs=1e-9)            # a path of n - 1 vehicles


@pytest.mark.parametrize('qos', [
    QoSProfile(depth=10),                                       # the ROS default: volatile
    QoSProfile(depth=5, reliability=ReliabilityPolicy.BEST_EFFORT)],  # sensor data
    ids=['volatile', 'best_effort'])
def test_a_vehicle_takes_an_ordinary_odometry_publisher(nodes, qos):
    """A driver's odometry remapped onto vehicle_1/odom: the vehicle matches it and commands."""
    cfg = CONFIG / 'particle_parallel.yaml'
    sc = scenario.load(cfg, ['num_vehicles:=1'])
    nodes.vehicle(1, cfg, 'num_vehicles:=1')
    cmds = nodes.collect(VehicleCommand, names.topic(1, 'cmd'), itf.STATE_QOS)
    odom = nodes.node.create_publisher(Odometry, names.topic(1, 'odom'), qos)
    assert nodes.spin_until(lambda: odom.get_subscription_count(), timeout=20)
    x = scenario.initial_state(sc)[:, 0]
    assert nodes.spin_until(lambda: cmds or odom.publish(itf.odom_msg(1, 0, x, 0j)),
                            timeout=20)
    assert messages.stamp_ns(cmds[0].header.stamp) == 0
    assert any('a publisher offers less' in m.msg for m in nodes.rosout)
