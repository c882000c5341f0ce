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

"""The formation_state record, the decode-or-check path, the delay and hears-me (no DDS)."""
import hashlib
from types import SimpleNamespace

from formation_control.core import scenario
from formation_control.protocol import intake, messages
from formation_control.protocol.intake import Rejection
from formation_control.protocol.lockstep import REPEATED
from formation_control.protocol.messages import FormationState, StateWire
from formation_control.protocol.names import DEFAULT_FRAMES, Frames
from formation_control.protocol.onboard import Delay
from formation_control.protocol.plant import Plant
from formation_control.protocol.vehicle import Vehicle
from formation_control.sim import simulator
import numpy as np
import pytest
from runs import CONFIG

X = np.array([1.5, -2.0, 0.3, -0.2, 1.1, 0.05])
ROW = (1.5 - 2.0j, 0.7, -0.1, 1.1)
NS = 1_795_000_123_456_789_012
OTHER = Frames('world', 'robot_{id}/base')

GOLDEN = [   # sha256 of the bytes StateWire wrote before the record (commit 40cf5cb)
    (1, (), (), None, DEFAULT_FRAMES,
     '1273e24bb88a64dbe601f344c1693366f44ea59638f95f7cfd5bd55fcf7883bf'),
    (1, (), (), None, OTHER, '21c9be48391de97655e130e46bf302836e4e60dd4ba01ad4ae9cc092c81d06d1'),
    (3, (2, 4), (True, False), None, DEFAULT_FRAMES,
     'b291275b099734db0c20a48e4c84e9df9e36613055332478664f1507be9405fc'),
    (3, (2, 4), (True, False), None, OTHER,
     'cce73e9149d298f4b2e81de11e8dd1d9b9b5aab5a3e59fbd996b8547f0a5109a'),
    (12, (1, 5, 11), (False, True, True), 0.25 - 0.5j, DEFAULT_FRAMES,
     '8c09771a7ecf7e5ceb7b3cf87e068897f8ff332f021963a2f15a0b8b596e5457'),
    (12, (1, 5, 11), (False, True, True), 0.25 - 0.5j, OTHER,
     '68cea6b3f23b64e9203b135fe9f9ba2331cafe71bd2c6b02f680c021e5623b04'),
    (7, (), (), -1.0 + 0.125j, DEFAULT_FRAMES,
     'd6d7bef376e3780599dd6237f0ba15bafddd74cf580a77e66e6ccc8d6fe0b8a1'),
    (7, (), (), -1.0 + 0.125j, OTHER,
     'b2dcae9837dcd3ccc8f33151eaea94a5bfc71bbbf5fe14958bfcb7951f72b725'),
]


def _state(hears, hearing, flow_hat, ns=NS):
    return FormationState.of_vehicle(ns, X, ROW, dict(zip(hears, hearing)), flow_hat)


@pytest.mark.parametrize('k, hears, hearing, flow_hat, frames, digest', GOLDEN)
def test_the_record_writes_exactly_the_bytes_of_before(k, hears, hearing, flow_hat, frames,
                                                       digest):
    wire = StateWire(k, hears, frames, flow_hat is not None)
    state = _state(hears, hearing, flow_hat)
    data = wire.encode(state)
    assert hashlib.sha256(data).hexdigest() == digest
    assert wire.decode(data) == state
    assert StateWire(k + 1, hears, frames, flow_hat is not None).decode(data) is None
    assert wire.decode(data[:-20]) is None


@pytest.mark.parametrize('k, hears, hearing, flow_hat, frames, digest', GOLDEN)
def test_the_record_round_trips_the_joint_state_arrays(k, hears, hearing, flow_hat, frames,
                                                       digest):
    state = _state(hears, hearing, flow_hat)
    names, values = state.names(), state.values()
    assert names == messages.state_names(hears, flow_hat is not None)
    assert names[:7] == messages.STATE_FIELDS
    assert values[:7] == (1.5, -2.0, 0.3, -0.2, 0.7, -0.1, 1.1)
    assert values[7:7 + len(hears)] == tuple(float(h) for h in hearing)
    assert FormationState.from_joint(NS, names, values) == state
    assert state.r == ROW[0] and state.row == ROW
    assert state.flow_hat == flow_hat


def test_a_formation_state_is_read_by_its_names():
    state = FormationState.from_joint(5, ['x', 'y', 'heading', 'yaw_rate', 'phase',
                                          'phase_rate', 'speed', 'hears_4', 'hears_6'],
                                      [1, 2, 3, 4, 5, 6, 7, 0.9, 0.1])
    assert (state.stamp, state.x, state.speed) == (5, 1.0, 7.0)
    assert state.hears == {4: True, 6: False}
    assert state.flow_hat is None
    assert state.hears_vehicle(4) and not state.hears_vehicle(6)
    assert state.hears_vehicle(2)                    # not its graph neighbour: not flagged
    with pytest.raises(ValueError, match='names of a formation_state'):
        FormationState.from_joint(0, ['x'] * 5, [1.0] * 5)
    with pytest.raises(ValueError, match='hears_j'):
        FormationState.from_joint(0, [*messages.STATE_FIELDS, 'hears_me'], [0.0] * 8)
    with pytest.raises(ValueError):
        FormationState.from_joint(0, messages.STATE_FIELDS, [0.0] * 6)
    assert not FormationState.from_joint(0, messages.STATE_FIELDS,
                                         [0.0] * 6 + [float('nan')]).finite()


def test_a_stamp_splits_into_seconds_and_nanoseconds():
    header = SimpleNamespace(stamp=SimpleNamespace(sec=0, nanosec=0))
    messages.set_stamp(header, NS)
    assert (header.stamp.sec, header.stamp.nanosec) == messages.stamp_parts(NS) == (
        1_795_000_123, 456_789_012)
    assert messages.stamp_ns(header.stamp) == NS


def _joint(state, frame, names=None):
    return SimpleNamespace(header=SimpleNamespace(stamp=SimpleNamespace(
        sec=state.stamp // 10**9, nanosec=state.stamp % 10**9), frame_id=frame),
        name=list(state.names() if names is None else names), position=list(state.values()))


def _from(msg):
    def deserialize(data):
        if data == b'garbage':
            raise RuntimeError('not CDR')
        return msg
    return deserialize


def test_canonical_bytes_are_read_in_place_and_others_checked():
    wire = StateWire(3, (2, 4))
    rule = intake.formation_state(wire, DEFAULT_FRAMES)
    state = _state((2, 4), (True, False), None)
    assert rule(wire.encode(state), _from(None)) == state          # never deserialized
    assert rule(b'other', _from(_joint(state, 'vehicle_3/base_link'))) == state
    cases = {b'garbage': (None, 'malformed', 'undecodable formation_state of vehicle 3 bytes'),
             b'names': (_joint(state, 'vehicle_3/base_link', ['x'] * 9), 'malformed',
                        'a malformed formation_state of vehicle 3'),
             b'foreign': (_joint(state, 'vehicle_9/base_link'), 'foreign_id',
                          "a formation_state on vehicle 3's topic from 'vehicle_9/base_link'"),
             b'frame': (_joint(state, 'map'), 'wrong_frame',
                        "a formation_state on vehicle 3's topic from 'map'")}
    for data, (msg, kind, what) in cases.items():
        assert rule(data, _from(msg)) == Rejection(kind, what)
    unchecked = intake.formation_state(wire)                       # the monitor's: no frame
    assert unchecked(b'frame', _from(_joint(state, 'map'))) == state


def test_odometry_and_commands_are_checked_for_their_frames():
    stamp = SimpleNamespace(sec=1, nanosec=5)

    def odom(frame, child):
        pose = SimpleNamespace(position=SimpleNamespace(x=1.0, y=2.0),
                               orientation=SimpleNamespace(z=0.0, w=1.0))
        twist = SimpleNamespace(linear=SimpleNamespace(x=0.5, y=0.0),
                                angular=SimpleNamespace(z=0.1))
        return SimpleNamespace(header=SimpleNamespace(stamp=stamp, frame_id=frame),
                               child_frame_id=child, pose=SimpleNamespace(pose=pose),
                               twist=SimpleNamespace(twist=twist))
    none = SimpleNamespace(decode=lambda data: None)
    rule = intake.odometry(none, 2, 'map', 'vehicle_2/base_link')
    good = rule(b'x', _from(odom('map', 'vehicle_2/base_link')))
    assert good == (1_000_000_005, (1.0, 2.0, 0.0, 1.0, 0.5, 0.0, 0.1))
    assert rule(b'x', _from(odom('odom', 'vehicle_2/base_link'))).kind == 'wrong_frame'
    assert rule(b'x', _from(odom('map', 'vehicle_3/base_link'))).kind == 'wrong_frame'
    assert rule(b'garbage', _from(None)) == Rejection(
        'malformed', 'undecodable odometry of vehicle 2 bytes')
    assert intake.odometry(none, 2, 'map')(b'x', _from(odom('map', 'x'))) == good
    cmd = SimpleNamespace(header=SimpleNamespace(stamp=stamp, frame_id='map'),
                          wrench=SimpleNamespace(force=SimpleNamespace(x=1.0, y=2.0),
                                                 torque=SimpleNamespace(z=3.0)))
    assert intake.command(none, 2, 'vehicle_2/base_link')(b'x', _from(cmd)) == Rejection(
        'wrong_frame', "a command on vehicle 2's topic in frame 'map'")
    assert intake.command(none, 2)(b'x', _from(cmd)) == (1_000_000_005, (1.0, 2.0, 3.0))


def test_the_delay_is_a_running_mean_of_clipped_delays_plus_the_wait():
    delay = Delay(period=0.02, wait=0.0025)
    assert delay.ahead == 0.0025
    delay.add(0.01)
    assert delay.mean == pytest.approx(0.001)
    delay.add(1.0)                                  # clipped to one period
    assert delay.mean == pytest.approx(0.001 + 0.1 * (0.02 - 0.001))
    assert delay.ahead == pytest.approx(delay.mean + 0.0025)
    for _ in range(500):
        delay.add(0.004)
    assert delay.mean == pytest.approx(0.004)


class FakeClock:
    def __init__(self):
        self.t = 100.0

    def __call__(self):
        return self.t


LINK = {'neighbor_timeout': 1.0}


def test_a_vehicle_counts_a_neighbour_only_while_it_hears_it_back():
    sc = scenario.load(CONFIG / 'particle_parallel.yaml', ['num_vehicles:=4',
                                                           'graph:=ring'])
    me = Vehicle(sc, 1, True, LINK, FakeClock())
    assert me.wire.hears == (2, 4)
    odom = messages.odom_values(X, 0j)
    mine = me.odometry(0, odom)
    assert mine.hears == {2: True, 4: True} and mine.stamp == 0
    assert me.odometry(0, odom) is REPEATED
    assert me.odometry(-1, odom).kind == 'stale'
    assert me.odometry(20, (float('nan'),) * 7).kind == 'non_finite'
    deaf = FormationState(0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, {1: False, 3: True})
    hearing = FormationState(0, -1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, {1: True, 3: True})
    assert me.heard(2, deaf) is True and me.heard(4, hearing) is True
    due = me.command()
    assert due is not None and due[0] == 0 and due[2]
    assert list(me.known.hears_me) == [True, False, True, True]
    assert me.command() is None                     # the step is commanded
    assert me.heard(2, deaf._replace(stamp=20)) is True
    assert me.heard(2, deaf).kind == 'stale'
    gone, text, values = me.status({'stale': 1})
    assert (gone, text) == ([], '2 neighbours live')
    assert values['stale'] == 1 and values['live_neighbours'] == 2


@pytest.mark.parametrize('name', ['particle_parallel_flow', 'rigid_circular_flow_center',
                                  'first_order_circular'])
def test_the_plant_and_vehicle_protocols_without_dds_fly_the_offline_simulator(name):
    """Odometry values, state bytes and command values as the nodes pass them, one step each."""
    sc = scenario.load(CONFIG / f'{name}.yaml', ['num_vehicles:=4', 'duration:=0.4',
                                                 'graph:=ring', 'informed:=[1, 3]'], seed=3)
    clock = FakeClock()
    plant = Plant(sc, True, 2.0, clock)
    vehicles = [Vehicle(sc, k, True, LINK, clock) for k in (1, 2, 3, 4)]
    wires = {k: StateWire.of(sc, k) for k in (1, 2, 3, 4)}
    assert wires[1].hears == (2, 4)
    due = np.ones(4, bool), plant.begin(), True
    while due is not None:
        which, ns, step = due
        assert step and which.all()
        X, flow = plant.fleet.X, plant.fleet.local_flow()
        sent = {}
        for v in vehicles:
            got = v.odometry(ns, messages.odom_values(X[:, v.k - 1], flow[v.k - 1]))
            if v.second == 'flow':
                got = v.flow_heard(ns, flow[v.k - 1], 'map')
            sent[v.k] = wires[v.k].encode(got)
        for v in vehicles:
            for j in sc.comm_graph.neighbours(v.k):
                assert v.heard(j, wires[j].decode(sent[j])) is True
        for v in vehicles:
            ns_u, u, _ = v.command()
            assert plant.command(v.k, ns_u, messages.cmd_values(u, sc.model)) is True
        due = plant.advance()
    assert plant.finished and not plant.failed and not plant.errors
    run, ref = plant.fleet.run({}), simulator.simulate(sc)
    np.testing.assert_allclose(run.X, ref.X, rtol=0, atol=1e-9)
    np.testing.assert_allclose(run.U, ref.U, rtol=0, atol=1e-9)


def test_the_plant_protocol_refuses_bad_commands_and_reports_who_it_waits_for():
    sc = scenario.load(CONFIG / 'particle_parallel.yaml', ['num_vehicles:=2'])
    clock = FakeClock()
    plant = Plant(sc, True, 2.0, clock)
    assert plant.advance() is None                  # not started
    ns = plant.begin()
    assert plant.command(1, ns, (0.0, 0.0, float('nan'))) == Rejection(
        'non_finite', 'a non-finite command of vehicle 1')
    assert plant.command(1, ns + 1, (0.0, 0.0, 0.1)) == Rejection(
        'stale', 'a command of vehicle 1 for another step')
    assert plant.command(1, ns, (0.0, 0.0, 0.1)) is True
    assert plant.command(1, ns, (0.0, 0.0, 0.1)) is False      # the step answered again
    assert plant.advance() is None                  # vehicle 2 still awaited
    clock.t += 5.0
    assert plant.stalled(3.0) == (pytest.approx(5.0), [2])
    level, text, values = plant.status({'stale': 1})
    assert (level, values['step'], values['stale'], values['repeated_commands']) == (
        'ok', 0, 1, 1)
    assert plant.command(2, ns, (0.0, 0.0, -0.1)) is True
    which, ns1, step = plant.advance()
    assert which.all() and step and ns1 == round(sc.dt_control * 1e9)
    assert plant.fleet.pending[1].tolist() == [0.1, -0.1]
