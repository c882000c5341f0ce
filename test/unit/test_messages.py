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
from collections import Counter
import struct
from types import SimpleNamespace

from formation_control.bags import reader
from formation_control.core import scenario
from formation_control.core.models import ground_velocity
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

CASES = [   # k, graph neighbours, whether it hears each, flow estimate, frames
    (1, (), (), None, DEFAULT_FRAMES),
    (1, (), (), None, OTHER),
    (3, (2, 4), (True, False), None, DEFAULT_FRAMES),
    (12, (1, 5, 11), (False, True, True), 0.25 - 0.5j, OTHER),
    (7, (), (), -1.0 + 0.125j, DEFAULT_FRAMES),
]
AHEAD = 10_000_000


def _state(hears, hearing, flow_hat, ns=NS):
    return FormationState.of_vehicle(ns, X, ROW, dict(zip(hears, hearing)), flow_hat, AHEAD)


def _message(k, state, frame='map', **changes):
    """Return a FormationState message as a bag reader builds one: attributes only."""
    fields = {**state.fields(), 'vehicle_id': k, 'interface_version': 1, **changes}
    return SimpleNamespace(header=SimpleNamespace(stamp=_time(state.stamp), frame_id=frame),
                           predicted_stamp=_time(state.predicted_stamp), **fields)


def _time(ns):
    return SimpleNamespace(sec=ns // 10**9, nanosec=ns % 10**9)


@pytest.mark.parametrize('k, hears, hearing, flow_hat, frames', CASES)
def test_the_wire_reads_back_what_it_writes_and_only_its_own_layout(k, hears, hearing, flow_hat,
                                                                    frames):
    wire = StateWire(k, hears, frames, flow_hat is not None)
    state = _state(hears, hearing, flow_hat)
    data = wire.encode(state)
    assert wire.decode(data) == state
    assert state.predicted_stamp == NS + AHEAD and state.flow_hat == flow_hat
    assert StateWire(k + 1, hears, frames, flow_hat is not None).decode(data) is None
    assert StateWire(k, hears, Frames('odom'), flow_hat is not None).decode(data) is None
    assert StateWire(k, hears, frames, flow_hat is None).decode(data) is None
    assert wire.decode(data[:-8]) is None
    assert wire.decode(data[:4] + bytes([2]) + data[5:]) is None        # interface version 2
    assert data[4] == messages.INTERFACE_VERSION


def test_the_wire_bytes_are_the_cdr_of_the_msg_definition():
    """Hand-checked offsets of FormationState.msg in XCDR1 (body from byte 4, aligned there)."""
    state = _state((2, 4), (True, False), 0.25 - 0.5j)
    data = StateWire(3, (2, 4), DEFAULT_FRAMES, True).encode(state)
    body = data[4:]
    sec, nanosec = messages.stamp_parts(NS)
    psec, pnanosec = messages.stamp_parts(NS + AHEAD)
    assert data[:4] == b'\x00\x01\x00\x00' and body[0] == 1                # interface_version
    assert struct.unpack_from('<iII4s', body, 4) == (sec, nanosec, 4, b'map\x00')
    assert struct.unpack_from('<IiI', body, 20) == (3, psec, pnanosec)     # vehicle_id, stamp
    assert struct.unpack_from('<7d', body, 32) == (1.5, -2.0, 0.3, -0.2, 0.7, -0.1, 1.1)
    assert struct.unpack_from('<4I3?', body, 88) == (2, 2, 4, 2, True, False, True)
    assert struct.unpack_from('<2d', body, 112) == (0.25, -0.5) and len(body) == 128


@pytest.mark.parametrize('k, hears, hearing, flow_hat, frames', CASES)
def test_a_message_reads_as_the_wire_reads_its_bytes(k, hears, hearing, flow_hat, frames):
    state = _state(hears, hearing, flow_hat)
    assert FormationState.of_message(_message(k, state, frames.world)) == state
    assert state.r == ROW[0] and state.row == ROW


def test_a_state_says_whom_the_sender_hears():
    state = FormationState(5, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, {4: True, 6: False})
    assert (state.stamp, state.x, state.speed, state.predicted_stamp) == (5, 1.0, 7.0, 5)
    assert state.flow_hat is None and state.finite()
    assert state.hears_vehicle(4) and not state.hears_vehicle(6)
    assert state.hears_vehicle(2)                    # not its graph neighbour: not flagged
    assert not state._replace(speed=float('nan')).finite()
    assert not state._replace(flow_hat=complex(0.0, float('inf'))).finite()


def test_a_stamp_splits_into_seconds_and_nanoseconds():
    header = SimpleNamespace(stamp=SimpleNamespace(sec=0, nanosec=0))
    messages.set_stamp(header, NS)
    assert (header.stamp.sec, header.stamp.nanosec) == messages.stamp_parts(NS) == (
        1_795_000_123, 456_789_012)
    assert messages.stamp_ns(header.stamp) == NS


def _from(msg):
    def deserialize(data):
        if data.startswith(b'garb'):
            raise RuntimeError('not CDR')
        return msg
    return deserialize


def test_a_clock_of_negative_time_is_malformed_not_handed_to_rclpy():
    """A negative time: rclpy's time source raises on it in the callback (the recorder died)."""
    def clock(sec):
        return SimpleNamespace(clock=SimpleNamespace(sec=sec, nanosec=5))
    rule = intake.clock('Clock on /clock')
    fine = clock(0)
    assert rule(b'x', _from(fine)) is fine
    assert rule(b'x', _from(clock(-1041558194))) == Rejection(
        'malformed', 'a Clock on /clock of negative time (-1041558194 s)')
    assert rule(b'garbage', _from(None)).kind == 'malformed'


def test_canonical_bytes_are_read_in_place_and_others_checked():
    wire = StateWire(3, (2, 4))
    rule = intake.formation_state(wire, DEFAULT_FRAMES)
    state = _state((2, 4), (True, False), None)
    assert rule(wire.encode(state), _from(None)) == state          # never deserialized
    assert rule(b'other', _from(_message(3, state))) == state
    cases = {b'garb\x01age': (None, 'malformed',
                              'undecodable formation_state of vehicle 3 bytes'),
             b'graph': (_message(3, state, neighbour_ids=[2, 5]), 'malformed',
                        'a malformed formation_state of vehicle 3 (neighbours [2, 5], 2 hears '
                        'flags, estimates_flow False; its graph and flow_source give [2, 4], '
                        'False)'),
             b'foreign': (_message(9, state), 'foreign_id',
                          "a formation_state of vehicle 9 on vehicle 3's topic"),
             b'frame': (_message(3, state, 'odom'), 'wrong_frame',
                        "a formation_state on vehicle 3's topic in frame 'odom' (world_frame is "
                        "'map')"),
             b'version': (_message(3, state, interface_version=2), 'interface_version',
                          'a formation_state of vehicle 3 of interface version 2: this node '
                          'speaks formation_control_msgs version 1 (run the same '
                          'formation_control_msgs on every node)')}
    for data, (msg, kind, what) in cases.items():
        assert rule(data, _from(msg)) == Rejection(kind, what)
    newer = rule(b'garb\x02age', _from(None))                     # version 2, undecodable
    assert newer == Rejection('malformed', 'undecodable formation_state of vehicle 3 bytes '
                                           '(their first field, interface_version, reads 2; '
                                           'this node speaks formation_control_msgs version 1)')
    unchecked = intake.formation_state(wire)                       # the monitor's: no frame
    assert unchecked(b'frame', _from(_message(3, state, 'odom'))) == state


def test_odometry_and_commands_are_checked_for_their_frames_ids_and_kinds():
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

    def cmd(frame='vehicle_2/base_link', **changes):
        fields = {'interface_version': 1, 'vehicle_id': 2, 'kind': 2, 'thrust': 0.0,
                  'steering_force': 0.0, 'angular_acceleration': 3.0, 'turn_rate': 0.0,
                  **changes}
        return SimpleNamespace(header=SimpleNamespace(stamp=stamp, frame_id=frame), **fields)
    wire = messages.CommandWire(2, 'second_order')
    rule = intake.command(wire, 'vehicle_2/base_link')
    assert rule(b'x', _from(cmd())) == (1_000_000_005, (0.0, 0.0, 3.0, 0.0))
    assert rule(wire.encode(7, (0.0, 0.0, 0.5, 0.0)), _from(None)) == (7, (0.0, 0.0, 0.5, 0.0))
    assert rule(b'x', _from(cmd('map'))) == Rejection(
        'wrong_frame', "a command on vehicle 2's topic in frame 'map'")
    assert rule(b'x', _from(cmd(kind=0))) == Rejection(
        'wrong_kind', 'a command of vehicle 2 of kind 0 (its model takes kind 2; 0 is no kind)')
    assert rule(b'x', _from(cmd(kind=3))).kind == 'wrong_kind'
    assert rule(b'x', _from(cmd(vehicle_id=1))).kind == 'foreign_id'
    assert rule(b'x', _from(cmd(interface_version=0))).kind == 'interface_version'
    assert intake.command(wire)(b'x', _from(cmd('map'))) == (1_000_000_005, (0.0, 0.0, 3.0, 0.0))


def test_an_aircraft_cmd_vel_is_checked_for_its_frame_and_finite_values():
    def twist(frame='vehicle_2/base_link', x=51.0, z=0.05):
        return SimpleNamespace(header=SimpleNamespace(stamp=SimpleNamespace(sec=1, nanosec=5),
                                                      frame_id=frame),
                               twist=SimpleNamespace(linear=SimpleNamespace(x=x, y=0.0),
                                                     angular=SimpleNamespace(z=z)))
    none = SimpleNamespace(decode=lambda data: None)
    rule = intake.autopilot_demand(none, 2, 'vehicle_2/base_link')
    assert rule(b'x', _from(twist())) == (1_000_000_005, (51.0, 0.05))
    assert rule(b'x', _from(twist('map'))) == Rejection(
        'wrong_frame', "a cmd_vel on vehicle 2's topic in frame 'map' (expected "
                       "'vehicle_2/base_link')")
    assert rule(b'x', _from(twist(z=float('inf')))).kind == 'non_finite'
    assert rule(b'garbage', _from(None)) == Rejection(
        'malformed', 'undecodable cmd_vel of vehicle 2 bytes')
    canonical = SimpleNamespace(decode=lambda data: (7, (float('nan'), 0.1)))
    nan = intake.autopilot_demand(canonical, 2, 'vehicle_2/base_link')(b'x', _from(None))
    assert nan == Rejection('non_finite', 'a non-finite cmd_vel of vehicle 2: airspeed, turn '
                                          'rate (nan, 0.1)')


@pytest.mark.parametrize('model, kind, values', [
    ('rigid', 1, (0.5, -0.25, 0.0, 0.0)), ('rigid_cop', 1, (0.5, -0.25, 0.0, 0.0)),
    ('second_order', 2, (0.0, 0.0, -0.25, 0.0)), ('first_order', 3, (0.0, 0.0, 0.0, -0.25))])
def test_a_command_names_what_its_model_takes(model, kind, values):
    assert messages.command_kind(model) == kind
    assert messages.cmd_values((0.5, -0.25), model) == values
    u = (0.5, -0.25) if kind == 1 else (0.0, -0.25)
    assert messages.input_from_cmd_values(values, model) == u
    wire = messages.CommandWire(4, model)
    assert wire.decode(wire.encode(NS, values)) == (NS, values)
    assert messages.CommandWire(5, model).decode(wire.encode(NS, values)) is None


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


@pytest.mark.parametrize('lockstep', [True, False])
def test_a_vehicle_says_what_it_waits_for_and_how_long_no_step_followed_its_command(lockstep):
    """Its odometry, its neighbours' states, then, once it answered, the silence since."""
    sc = scenario.load(CONFIG / 'particle_parallel.yaml', ['num_vehicles:=3'])
    clock = FakeClock()
    born = clock.t
    me = Vehicle(sc, 1, lockstep, LINK, clock)
    assert me.stalled(born + 2.9, born, 3.0) is None
    assert me.stalled(born + 3.1, born, 3.0) == 'odometry'
    clock.t += 10.0
    me.odometry(20, messages.odom_values(X, 0j))
    if lockstep:
        assert me.stalled(clock.t + 2.9, born, 3.0) is None
        assert me.stalled(clock.t + 3.5, born, 3.0) == (3.5, [2, 3])
        clock.t += 0.5
        for j in (2, 3):
            assert me.heard(j, FormationState(20, float(j), 0.0, 0.0, 0.0, 0.0, 0.0, 1.0))
    assert me.command() is not None
    assert me.stalled(clock.t + 3.0, born, 3.0) is None
    assert me.stalled(clock.t + 3.25, born, 3.0) == 3.25
    if lockstep:
        assert me.odometry(20, messages.odom_values(X, 0j)) is REPEATED
        assert me.stalled(clock.t + 3.25, born, 3.0) == 3.25  # a step asked again is no new one
    clock.t += 3.25
    me.odometry(40, messages.odom_values(X, 0j))              # a new step: the wait starts again
    assert me.stalled(clock.t + 2.9, born, 3.0) is None


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
    assert plant.command(1, ns, (0.0, 0.0, float('nan'), 0.0)) == Rejection(
        'non_finite', 'a non-finite command of vehicle 1')
    assert plant.command(1, ns + 1, (0.0, 0.0, 0.1, 0.0)) == Rejection(
        'stale', 'a command of vehicle 1 for another step')
    assert plant.command(1, ns, (0.0, 0.0, 0.1, 0.0)) is True
    assert plant.command(1, ns, (0.0, 0.0, 0.1, 0.0)) is False      # the step answered again
    assert plant.advance() is None                  # vehicle 2 still awaited
    clock.t += 5.0
    assert plant.stalled(3.0) == (pytest.approx(5.0), [2])
    level, text, values = plant.status({'stale': 1})
    assert (level, values['step'], values['stale'], values['repeated_commands']) == (
        'ok', 0, 1, 1)
    assert plant.command(2, ns, (0.0, 0.0, -0.1, 0.0)) is True
    which, ns1, step = plant.advance()
    assert which.all() and step and ns1 == round(sc.dt_control * 1e9)
    assert plant.fleet.pending[1].tolist() == [0.1, -0.1]


def _odometry(values):
    """Return an Odometry stand-in with the ODOM_FIELDS ``values``."""
    def node(*names):
        return SimpleNamespace(**dict.fromkeys(names, 0.0))
    msg = SimpleNamespace(pose=SimpleNamespace(pose=SimpleNamespace(
        position=node('x', 'y', 'z'), orientation=node('x', 'y', 'z', 'w'))),
        twist=SimpleNamespace(twist=SimpleNamespace(linear=node('x', 'y', 'z'),
                                                    angular=node('x', 'y', 'z'))))
    return messages.set_fields(msg, messages.ODOM_FIELDS, values)


@pytest.mark.parametrize('name', ['particle_circular_flow', 'rigid_circular_flow_center'])
def test_a_bags_odometry_in_a_gust_gives_the_state_and_the_gust_back(name):
    """The bag reader keeps the gust the plant's odometry carries (issue 43, item 2)."""
    sc = scenario.load(CONFIG / f'{name}.yaml', [], gust_intensity=0.1)
    stepper = simulator.Stepper(sc)
    stepper.command()
    stepper.advance()
    X, flow, field = stepper.X, stepper.true_flow(), stepper.local_flow()
    t = stepper.t
    samples = [(round(t * 1e9), k, _odometry(messages.odom_values(X[:, k], flow[k])), 'odom')
               for k in range(sc.num_vehicles)]
    samples.insert(0, (0, 0, _odometry(messages.odom_values(X[:, 0], flow[0])), 'odom'))
    got = reader._periods(sc, samples, Counter(), 'bag')[round(t / sc.dt_control)]
    state = np.column_stack([got[k][1] for k in range(sc.num_vehicles)])
    gust = np.array([got[k][2] for k in range(sc.num_vehicles)])
    assert np.all(abs(flow - field) > 1e-3)
    np.testing.assert_allclose(ground_velocity(state, field) + gust, ground_velocity(X, flow),
                               atol=1e-9)
    if name.startswith('particle'):                  # its state has no place for the gust
        np.testing.assert_allclose(gust, flow - field, atol=1e-9)
