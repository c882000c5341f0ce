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
The plant and vehicle nodes: what each publishes, how parameters are set, refused and changed.

The executables run as real processes (no launch_testing) where the property is the process'
own (its command line and parameter file, the participant lock, a clean exit 0 on SIGINT); the
other properties are tested on the same nodes built in this process (the ``nodes`` fixture).
"""
import math
from pathlib import Path
import re

from formation_control.core import scenario
from formation_control.core.control import Controller
from formation_control.core.errors import ScenarioError
from formation_control.core.laws import View
from formation_control.core.scenario import initial_state
from formation_control.protocol import messages, names
from formation_control.ros import interface as itf
from formation_control_msgs.msg import FormationState, VehicleCommand
from geometry_msgs.msg import Vector3Stamped
from nav_msgs.msg import Odometry
import numpy as np
import pytest
from rcl_interfaces.msg import Parameter as ParameterMsg, ParameterType, ParameterValue
from rcl_interfaces.srv import DescribeParameters, GetParameters, SetParameters
from rclpy.exceptions import InvalidParameterTypeException, InvalidParameterValueException
from rosgraph_msgs.msg import Clock
from rosutil import CONFIG, interrupt

PARTICLE = CONFIG / 'particle_parallel.yaml'


def _args(path, *params):
    out = ['--ros-args', '--params-file', path]
    for p in params:
        out += ['-p', p]
    return out


def test_plant_publishes_initial_state_owns_the_clock_and_exits_on_sigint(ros):
    plant = ros.procs.start('plant', *_args(PARTICLE, 'num_vehicles:=3', 'flow:=[0.2, -0.1]',
                                            'exit_when_done:=false'))
    odom = ros.probe.collect(Odometry, '/vehicle_2/odom', itf.STATE_QOS)
    flow = ros.probe.collect(Vector3Stamped, '/vehicle_3/flow', itf.LATCHED_QOS)
    clock = ros.probe.collect(Clock, '/clock', itf.LATCHED_QOS)
    assert ros.probe.spin_until(lambda: odom and flow and clock)
    sc = scenario.load(PARTICLE, ['num_vehicles:=3', 'flow:=[0.2, -0.1]'])
    X = initial_state(sc)[:, 1]
    msg = odom[0]
    assert msg.header.frame_id == 'map' and msg.child_frame_id == 'vehicle_2/base_link'
    assert messages.stamp_ns(msg.header.stamp) == 0
    assert (msg.pose.pose.position.x, msg.pose.pose.position.y) == pytest.approx((X[0], X[1]))
    q = msg.pose.pose.orientation
    assert 2 * math.atan2(q.z, q.w) == pytest.approx(math.remainder(X[2], 2 * math.pi))
    ground_body = (1 + complex(0.2, -0.1) * np.exp(-1j * X[2]))
    assert msg.twist.twist.linear.x == pytest.approx(ground_body.real)
    assert msg.twist.twist.linear.y == pytest.approx(ground_body.imag)
    assert (flow[0].vector.x, flow[0].vector.y) == pytest.approx((0.2, -0.1))
    assert clock[0].clock.sec == 0 and clock[0].clock.nanosec == 0     # lockstep: its /clock
    assert interrupt(plant) == 0


def _waits_for_a_lock(pid):
    """Whether process ``pid`` is blocked on a file lock (a ``->`` line of /proc/locks)."""
    return re.search(rf'^\d+: -> FLOCK\s+ADVISORY\s+WRITE\s+{pid}\s',
                     Path('/proc/locks').read_text(), re.M) is not None


def test_a_node_waits_for_the_participant_lock_before_joining(ros):
    """Participants are created one at a time (a Fast DDS start-up race, docs/benchmarks.md)."""
    from formation_control.ros.runner import one_participant_at_a_time
    odom = ros.probe.collect(Odometry, '/vehicle_1/odom', itf.STATE_QOS)
    with one_participant_at_a_time():
        plant = ros.procs.start('plant', *_args(PARTICLE, 'num_vehicles:=1',
                                                'exit_when_done:=false'))
        assert ros.probe.spin_until(lambda: _waits_for_a_lock(plant.pid)     # its imports
                                    or plant.poll() is not None, timeout=60)  # under load
        assert plant.poll() is None
        assert not ros.probe.spin_until(lambda: odom, timeout=0.5)
        assert 'plant' not in ros.probe.node.get_node_names()
    assert ros.probe.spin_until(lambda: odom)
    assert interrupt(plant) == 0


def test_realtime_plant_samples_each_vehicle_in_its_own_slot_of_the_period(nodes):
    """Vehicle k's odometry comes every period, (k - 1) mod substeps integration steps in."""
    ids = (1, 2, 10, 11, 12)
    odom = {k: nodes.collect(Odometry, names.topic(k, 'odom'), itf.STATE_QOS) for k in ids}
    nodes.plant(PARTICLE, 'num_vehicles:=12', 'mode:=realtime', 'exit_when_done:=false',
                'wait_for_fleet:=false')
    assert nodes.spin_until(lambda: all(len(msgs) > 5 for msgs in odom.values()))
    sc = scenario.load(PARTICLE)
    period, step = (round(dt * 1e9) for dt in (sc.dt_control, sc.dt_integration))
    assert sc.substeps == 4
    stamps = {k: np.array([messages.stamp_ns(m.header.stamp) for m in msgs])
              for k, msgs in odom.items()}
    start = stamps[1][0]
    for k in ids:
        gaps = np.diff(stamps[k])                    # a slow probe may lose one from its history
        assert np.all((gaps > 0) & (gaps % period == 0)) and np.median(gaps) == period, k
        assert (stamps[k][0] - start) % period == ((k - 1) % sc.substeps) * step, k


def test_realtime_plant_starts_the_clock_once_every_vehicle_is_up(nodes):
    odom = nodes.collect(Odometry, names.topic(1, 'odom'), itf.STATE_QOS)
    plant = nodes.plant(PARTICLE, 'num_vehicles:=2', 'mode:=realtime', 'exit_when_done:=false')
    cmd = [nodes.node.create_publisher(VehicleCommand, names.topic(1, 'cmd'), itf.STATE_QOS)]
    assert nodes.spin_until(lambda: nodes.logged(plant, 'real time starts once vehicles [2] '
                                                        'are up'))
    assert not nodes.spin_until(lambda: odom, timeout=0.5)      # the plant checks every 0.05 s
    cmd.append(nodes.node.create_publisher(VehicleCommand, names.topic(2, 'cmd'), itf.STATE_QOS))
    assert nodes.spin_until(lambda: len(odom) > 2)
    assert nodes.logged(plant, 'every vehicle is up: real time starts')
    sc = scenario.load(PARTICLE)
    stamps = [messages.stamp_ns(m.header.stamp) for m in odom]
    assert np.all(np.diff(stamps) == round(sc.dt_control * 1e9))


def test_vehicle_answers_its_neighbours_with_state_and_command(nodes):
    """Vehicle 1 of 2 gets its odometry and vehicle 2's state for t = 0.4 s, and commands."""
    nodes.vehicle(1, PARTICLE, 'num_vehicles:=2')
    node = nodes.node
    odom_pub = node.create_publisher(Odometry, '/vehicle_1/odom', itf.STATE_QOS)
    state_pub = node.create_publisher(FormationState, '/vehicle_2/formation_state',
                                      itf.STATE_QOS)
    states = nodes.collect(FormationState, '/vehicle_1/formation_state', itf.STATE_QOS)
    cmds = nodes.collect(VehicleCommand, '/vehicle_1/cmd', itf.STATE_QOS)
    assert nodes.spin_until(lambda: odom_pub.get_subscription_count() > 0
                            and state_pub.get_subscription_count() > 0)
    sc = scenario.load(PARTICLE, ['num_vehicles:=2'])
    ctrl = Controller(sc)
    X = np.array([[0.5, -1.0], [1.0, 2.0], [0.3, 2.5], [0.2, -0.4], [1.0, 1.0], [0.0, 0.0]])
    sent = ctrl.view(X[:, [1]])
    own = ctrl.predict(X[:, [0]], np.zeros((2, 1)))      # half a period on, nothing held yet
    mine = ctrl.view(own)
    view = View(*(np.r_[getattr(mine, name), getattr(sent, name)]
                  for name in ('r', 'phase', 'rate', 'speed')), np.r_[mine.speed_dot, 0.0])
    expected = ctrl.command(view, own, [0])
    ns = 400_000_000
    state_pub.publish(itf.state_msg(2, ns, X[:, 1], (sent.r[0], sent.phase[0], sent.rate[0],
                                                     sent.speed[0])))
    odom_pub.publish(itf.odom_msg(1, ns, X[:, 0], 0j))
    assert nodes.spin_until(lambda: cmds and states)
    state = states[0]
    assert (state.vehicle_id, state.header.frame_id, list(state.neighbour_ids)) == (1, 'map', [])
    assert messages.stamp_ns(state.header.stamp) == ns
    assert messages.stamp_ns(state.predicted_stamp) == ns + round(sc.dt_control / 2 * 1e9)
    heading = 0.3 + 0.2 * sc.dt_control / 2
    np.testing.assert_allclose(messages.get_fields(state, messages.STATE_FIELDS),
                               [mine.r[0].real, mine.r[0].imag, heading, 0.2, heading, 0.2, 1.0],
                               atol=1e-12)
    assert messages.stamp_ns(cmds[0].header.stamp) == ns
    assert (cmds[0].header.frame_id, cmds[0].vehicle_id) == ('vehicle_1/base_link', 1)
    assert (cmds[0].kind, cmds[0].interface_version) == (VehicleCommand.SECOND_ORDER, 1)
    assert cmds[0].angular_acceleration == pytest.approx(expected[1, 0], abs=1e-12)
    assert (cmds[0].thrust, cmds[0].steering_force, cmds[0].turn_rate) == (0.0, 0.0, 0.0)


def test_realtime_vehicle_predicts_over_half_a_period_half_a_step_and_its_delay(nodes):
    """
    Real time: a vehicle commands for its odometry carried ahead under the input it holds.

    Ahead by dt_control/2 + dt_integration/2 + its measured delay (its formation_state).
    """
    nodes.vehicle(1, PARTICLE, 'num_vehicles:=1', 'mode:=realtime')
    odom = nodes.node.create_publisher(Odometry, '/vehicle_1/odom', itf.STATE_QOS)
    states = nodes.collect(FormationState, '/vehicle_1/formation_state', itf.STATE_QOS)
    cmds = nodes.collect(VehicleCommand, '/vehicle_1/cmd', itf.STATE_QOS)
    assert nodes.spin_until(lambda: odom.get_subscription_count() > 0)
    sc = scenario.load(PARTICLE)
    X = np.array([0.5, 1.0, 0.3, 0.2, 1.0, 0.0])
    base = sc.dt_control / 2 + sc.dt_integration / 2
    leads = []
    for step in range(4):
        held = cmds[-1].angular_acceleration if cmds else 0.0
        odom.publish(itf.odom_msg(1, step * 20_000_000, X, 0j))
        assert nodes.spin_until(lambda: len(states) > step and len(cmds) > step)
        heading, yaw_rate = states[step].heading, states[step].yaw_rate
        leads.append((heading - 0.3) / 0.2 if step == 0 else (yaw_rate - 0.2) / held)
        stated = (messages.stamp_ns(states[step].predicted_stamp) - step * 20_000_000) * 1e-9
        assert stated == pytest.approx(leads[-1], abs=1e-6)      # predicted_stamp says how far
    assert leads[0] == pytest.approx(base, abs=1e-12)           # no delay measured yet
    assert all(base < lead < base + sc.dt_control for lead in leads[1:]), leads


def _call(probe, srv_type, name, request, timeout=15.0):
    client = probe.node.create_client(srv_type, name)
    assert client.wait_for_service(timeout_sec=timeout)
    future = client.call_async(request)
    assert probe.spin_until(future.done, timeout)
    return future.result()


def _double(name, value):
    return ParameterMsg(name=name, value=ParameterValue(
        type=ParameterType.PARAMETER_DOUBLE, double_value=value))


def test_parameters_from_yaml_and_run_time_changes(ros, tmp_path):
    params = tmp_path / 'fleet.yaml'
    params.write_text(PARTICLE.read_text().replace('kappa: 5.0', 'kappa: 3.5'))
    vehicle = ros.procs.start('vehicle', *_args(params, 'num_vehicles:=4', 'vehicle_id:=3'))
    name = '/vehicle_3'
    got = _call(ros.probe, GetParameters, f'{name}/get_parameters',
                GetParameters.Request(names=['kappa', 'num_vehicles', 'vehicle_id']))
    assert [v.double_value for v in got.values[:1]] == [3.5]
    assert [v.integer_value for v in got.values[1:]] == [4, 3]
    described = _call(ros.probe, DescribeParameters, f'{name}/describe_parameters',
                      DescribeParameters.Request(names=['kappa', 'num_vehicles']))
    kappa, num = described.descriptors
    assert 'kappa' in kappa.description and not kappa.read_only and num.read_only
    bad = _call(ros.probe, SetParameters, f'{name}/set_parameters',
                SetParameters.Request(parameters=[_double('K', 2.0)]))
    assert not bad.results[0].successful
    assert "parameter 'K'" in bad.results[0].reason and 'K < 0' in bad.results[0].reason
    locked = _call(ros.probe, SetParameters, f'{name}/set_parameters', SetParameters.Request(
        parameters=[ParameterMsg(name='num_vehicles', value=ParameterValue(
            type=ParameterType.PARAMETER_INTEGER, integer_value=5))]))
    assert not locked.results[0].successful
    ok = _call(ros.probe, SetParameters, f'{name}/set_parameters',
               SetParameters.Request(parameters=[_double('kappa', 2.0)]))
    assert ok.results[0].successful
    got = _call(ros.probe, GetParameters, f'{name}/get_parameters',
                GetParameters.Request(names=['kappa', 'K']))
    assert [v.double_value for v in got.values] == [2.0, -1.0]
    assert vehicle.poll() is None
    services = [n for n, _ in ros.probe.node.get_service_names_and_types()]
    assert f'{name}/get_type_description' in services
    assert not [n for n in services if n.startswith(('/vehicle/', '/_participant'))], services
    assert interrupt(vehicle) == 0


BAD_AT_START_UP = [
    ('vehicle', ['vehicle_id:=1', 'kappa:=-1.0'], 'kappa out of range'),
    ('vehicle', ['vehicle_id:=1', 'K:=1.0'], "parameter 'K' = 1.0 is invalid: formation parallel"),
    ('vehicle', ['vehicle_id:=17'], "parameter 'vehicle_id' = 17"),
    ('vehicle', [], "parameter 'vehicle_id'"),
    ('vehicle', ['vehicle_id:=1', 'kapa:=1.0'], "unknown parameter 'kapa' (did you mean "
     "'kappa'?)"),
    ('plant', ['formation:=circle'], "parameter 'formation' = 'circle'"),
    ('plant', ['mode:=fast'], "parameter 'mode' = 'fast'"),
    ('plant', ['num_vehicles:=0'], 'num_vehicles'),
    ('plant', ['kappa:=abc'], "parameter 'kappa' = 'abc' is invalid: a number"),
]
AS_PROCESSES = (0, 3, 5, 8)
"""Each way an executable refuses to start: a range (rclpy), the vehicle id (read by the
``vehicle`` executable before the node exists), the scenario (the node's own check), a type
(the command line's check, before rclpy). The other cases are refused by the same checks in
the node's constructor; they are built in process."""


@pytest.mark.parametrize('exe, params, named', [BAD_AT_START_UP[i] for i in AS_PROCESSES])
def test_bad_parameter_at_start_up_exits_with_code_2_naming_it(ros, exe, params, named):
    result = ros.procs.run(exe, *_args(CONFIG / 'first_order_parallel.yaml', *params))
    assert result.returncode == 2, result.stderr
    assert named in result.stderr + result.stdout


@pytest.mark.parametrize('exe, params, named', [case for i, case in enumerate(BAD_AT_START_UP)
                                                if i not in AS_PROCESSES])
def test_bad_parameter_at_start_up_is_refused_by_the_node_naming_it(nodes, exe, params, named):
    path = CONFIG / 'first_order_parallel.yaml'
    with pytest.raises((ScenarioError, InvalidParameterTypeException,
                        InvalidParameterValueException)) as refused:
        if exe == 'plant':
            nodes.plant(path, *params)
        else:
            nodes.vehicle(int(params[0].split(':=')[1]), path, *params[1:])
    assert named in str(refused.value)


@pytest.mark.parametrize('k, hears, hearing, flow_hat', [
    (1, (), (), None), (9, (8, 10), (True, False), None),
    (12, (1, 5, 11), (False, True, True), 0.25 - 0.5j), (345, (), (), 1j)])
def test_state_wire_bytes_are_the_formation_state_message(k, hears, hearing, flow_hat):
    """The vehicles' hand-written CDR is what rclpy makes of the same FormationState, and back."""
    from rclpy.serialization import deserialize_message, serialize_message
    X = np.array([1.5, -2.0, 0.3, -0.2, 1.1, 0.05])
    row = (1.5 - 2.0j, 0.7, -0.1, 1.1)
    ns = 1_795_000_123_456_789_012
    wire = messages.StateWire(k, hears, estimates=flow_hat is not None)
    state = messages.FormationState.of_vehicle(ns, X, row, dict(zip(hears, hearing)), flow_hat,
                                               ahead=12_500_000)
    msg = itf.formation_state_msg(k, state)
    data = wire.encode(state)
    assert deserialize_message(data, FormationState) == msg
    assert len(data) == len(serialize_message(msg))
    assert wire.decode(serialize_message(msg)) == state == wire.decode(data)
    assert messages.FormationState.of_message(msg) == state
    assert messages.StateWire(k + 1, hears).decode(data) is None
    assert wire.decode(data[:-20]) is None


@pytest.mark.parametrize('k', [1, 12, 345])
def test_odometry_and_command_bytes_are_the_messages(k):
    """The odometry and command wires write what rclpy serializes and refuse other layouts."""
    from rclpy.serialization import deserialize_message, serialize_message
    X = np.array([1.5, -2.0, 0.3, -0.2, 1.1, 0.05])
    ns, flow = 1_795_000_123_456_789_012, 0.3 - 0.1j
    odom = itf.odom_wire(k)
    data = odom.encode(ns, messages.odom_values(X, flow))
    assert deserialize_message(data, Odometry) == itf.odom_msg(k, ns, X, flow)
    assert data == serialize_message(itf.odom_msg(k, ns, X, flow))
    stamp, values = odom.decode(data)
    assert stamp == ns
    np.testing.assert_allclose(messages.state_from_odom_values(values, flow, 'rigid'), X,
                               atol=1e-12)
    other = itf.odom_msg(k, ns, X, flow)
    other.pose.covariance[0] = 0.1                             # a real odometry's covariance
    assert odom.decode(serialize_message(other)) is None
    assert itf.odom_wire(k + 1).decode(data) is None
    for model, u in (('rigid', (0.8, -0.02)), ('second_order', (0.0, 1.7)),
                     ('first_order', (0.0, -0.4))):
        cmd = itf.cmd_wire(k, model)
        data = cmd.encode(ns, messages.cmd_values(u, model))
        assert deserialize_message(data, VehicleCommand) == itf.cmd_msg(k, ns, u, model)
        assert cmd.decode(serialize_message(itf.cmd_msg(k, ns, u, model))) == cmd.decode(data)
        assert messages.input_from_cmd_values(cmd.decode(data)[1], model) == u
        assert itf.cmd_wire(k + 1, model).decode(data) is None
