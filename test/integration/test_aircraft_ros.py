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
JSBSim aircraft in the ROS nodes: the plant flies them, lockstep equals the offline simulator.

The plant node integrates each vehicle with its own FGFDMExec (plant_backend: jsbsim); each
vehicle node commands from its odometry in the map frame and sends its autopilot demand, the
interface of a guided autopilot mode, as geometry_msgs/TwistStamped on ``vehicle_k/cmd_vel``
(linear.x airspeed, angular.z turn rate, its base frame): the turn-rate demand the offline
simulator holds, which the plant's autopilot flies. The law's ``cmd`` is not the plant's input.
"""
from formation_control.core import scenario
from formation_control.protocol import messages, names
from formation_control.ros import interface as itf
from formation_control_msgs.msg import VehicleCommand
from geometry_msgs.msg import TwistStamped
from nav_msgs.msg import Odometry
import numpy as np
import pytest
from rosutil import CONFIG
from runs import assert_equal_runs, offline_run

pytest.importorskip('jsbsim')


@pytest.mark.parametrize('cfg', ['aircraft_circular', 'aircraft_parallel'])
def test_lockstep_aircraft_equal_the_offline_simulator(nodes, tmp_path, cfg):
    cfg = CONFIG / f'{cfg}.yaml'
    overrides = ['num_vehicles:=3', 'duration:=2.0']
    demands = nodes.collect(TwistStamped, names.topic(2, 'cmd_vel'), itf.STATE_QOS)
    fleet = nodes.lockstep_run(cfg, tmp_path / 'run.npz', *overrides)
    offline = offline_run(cfg, overrides)
    assert_equal_runs(fleet, offline)
    for name in ('altitude', 'bank', 'turn_rate_demand'):
        np.testing.assert_allclose(fleet.channels[name], offline.channels[name], rtol=0,
                                   atol=1e-6)
    assert np.ptp(offline.X[:, 2]) > 0.01                        # they turned
    sent = {messages.stamp_ns(m.header.stamp): m for m in demands}
    assert len(sent) >= offline.sc.periods // 2                  # depth 10 may drop a few
    first, period = min(sent), round(offline.sc.dt_control * 1e9)
    compared = 0
    for t, rate in zip(offline.t, offline.channels['turn_rate_demand'][:, 1]):
        msg = sent.get(first + round(t / offline.sc.dt_control) * period)
        if msg is not None:
            assert msg.header.frame_id == 'vehicle_2/base_link'
            assert msg.twist.linear.x == offline.sc.airspeed
            assert abs(msg.twist.angular.z - rate) < 1e-9
            compared += 1
    assert compared >= 3


def test_the_aircraft_plant_flies_cmd_vel_and_drops_a_wrong_frame(nodes):
    """Lockstep waits for cmd_vel; 0.05 rad/s demanded is flown, the cmd turning away is not."""
    cfg = CONFIG / 'aircraft_circular.yaml'
    overrides = ['num_vehicles:=1', 'duration:=16.0']
    sc = scenario.load(cfg, overrides)
    odom = nodes.collect(Odometry, names.topic(1, 'odom'), itf.STATE_QOS)
    cmd = nodes.node.create_publisher(VehicleCommand, names.topic(1, 'cmd'), itf.STATE_QOS)
    cmd_vel = nodes.node.create_publisher(TwistStamped, names.topic(1, 'cmd_vel'),
                                          itf.STATE_QOS)
    plant = nodes.plant(cfg, *overrides, 'exit_when_done:=false')
    assert nodes.spin_until(lambda: cmd_vel.get_subscription_count() > 0 and odom)
    assert cmd.get_subscription_count() == 0
    wrong = itf.water_velocity_msg(1, 0, np.zeros(6))
    wrong.header.frame_id = 'map'
    cmd_vel.publish(wrong)
    assert nodes.spin_until(lambda: plant.reject.counts['wrong_frame'] == 1)
    period, rates = round(sc.dt_control * 1e9), []
    for n in range(sc.periods + 1):
        ns = n * period
        assert nodes.spin_until(lambda: any(messages.stamp_ns(m.header.stamp) == ns
                                            for m in odom))
        rates.append(next(m.twist.twist.angular.z for m in odom
                          if messages.stamp_ns(m.header.stamp) == ns))
        cmd.publish(itf.cmd_msg(1, ns, (0.0, -2.0), sc.model))
        demand = TwistStamped()
        messages.set_stamp(demand.header, ns)
        demand.header.frame_id = 'vehicle_1/base_link'
        demand.twist.linear.x, demand.twist.angular.z = sc.airspeed, 0.05
        cmd_vel.publish(demand)
        del odom[:-20]
    assert nodes.spin_until(lambda: plant.plant.finished)
    late = np.array(rates[len(rates) // 2:])
    assert late.mean() == pytest.approx(0.05, abs=0.005)
    assert 0.045 < late.min() and late.max() < 0.06        # the cmd's a = -2: below -0.1
