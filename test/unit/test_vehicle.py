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


"""What the vehicle node asks of protocol.vehicle.Vehicle, through its own methods."""
from formation_control.core import scenario
from formation_control.protocol import messages
from formation_control.protocol.messages import FormationState, StateWire
from formation_control.protocol.onboard import DELAY_GAIN
from formation_control.protocol.vehicle import Vehicle
import numpy as np
import pytest
from runs import CONFIG

X = np.array([1.5, -2.0, 0.3, -0.2, 1.1, 0.05])


class FakeClock:
    def __init__(self):
        self.t = 100.0

    def __call__(self):
        return self.t


def _vehicle(lockstep=True, **link):
    sc = scenario.load(CONFIG / 'particle_parallel.yaml', ['num_vehicles:=4', 'graph:=ring'])
    clock = FakeClock()
    return Vehicle(sc, 1, lockstep, {'neighbor_timeout': 1.5, **link}, clock), clock


def _neighbour(j, ns):
    return FormationState(ns, float(j), 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, {1: True})


def test_its_liveness_timeout_and_whether_faults_are_injected():
    me, _ = _vehicle()
    assert me.liveness_timeout == 1.5 and not me.faults_active
    assert _vehicle(delay=0.1)[0].faults_active
    assert _vehicle(drop_probability=0.5)[0].faults_active


def test_cutting_links_drops_their_states_until_restored():
    me, _ = _vehicle(cut_links=(4,))
    assert me.cut == [4]
    assert me.cut_links([4, 2]) == [2, 4] and me.cut == [2, 4]
    me.odometry(0, messages.odom_values(X, 0j))
    assert me.heard(2, _neighbour(2, 0)) is False
    assert me.cut_links(()) == [] and me.cut == []
    assert me.heard(2, _neighbour(2, 0)) is True


def test_its_last_odometry_stamp_and_whether_it_was_answered():
    me, _ = _vehicle()
    assert me.odom_ns == -1
    me.odometry(20, messages.odom_values(X, 0j))
    assert me.odom_ns == 20 and not me.answered
    for j in (2, 4):
        me.heard(j, _neighbour(j, 20))
    assert me.command() is not None and me.answered
    me.odometry(40, messages.odom_values(X, 0j))
    assert me.odom_ns == 40 and not me.answered


def test_its_state_bytes_are_its_wire_layout():
    me, _ = _vehicle()
    state = me.odometry(20, messages.odom_values(X, 0j))
    data = me.encode(state)
    assert data == StateWire.of(me.sc, 1).encode(state)
    assert me.wire.decode(data) == state


def test_held_states_are_delivered_one_by_one_when_due():
    me, clock = _vehicle(delay=0.25)
    me.odometry(20, messages.odom_values(X, 0j))
    assert me.heard(2, _neighbour(2, 20)) is False and me.heard(4, _neighbour(4, 20)) is False
    assert list(me.deliver()) == []
    clock.t += 0.25
    delivered = me.deliver()
    assert next(delivered) is True and me.known.waiting().tolist() == [False] * 3 + [True]
    assert next(delivered) is True and list(delivered) == []
    assert me.command() is not None


def test_a_measured_delay_moves_the_prediction_ahead():
    me, _ = _vehicle(lockstep=False)
    before = me.delay.ahead
    me.measured_delay(0.01)
    assert me.delay.ahead == pytest.approx(before + DELAY_GAIN * 0.01)
