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

"""Namespaces, remapping, frames as parameters, run-time gains (in-process nodes)."""
from diagnostic_msgs.msg import DiagnosticArray
from formation_control.core import scenario
from formation_control.core.errors import ScenarioError
from formation_control.protocol import messages, names
from formation_control.ros import interface as itf, tuning
from formation_control.ros.monitor import MonitorNode
from formation_control.ros.plant import PlantNode
from formation_control.ros.vehicle import VehicleNode
from formation_control_msgs.msg import FormationState, VehicleCommand
from nav_msgs.msg import Odometry
import numpy as np
import pytest
from rcl_interfaces.msg import Parameter as ParameterMsg, ParameterEvent
from rclpy.parameter import Parameter
from rclpy.qos import qos_profile_parameter_events
from rosutil import CONFIG
from std_msgs.msg import String

PARTICLE = CONFIG / 'particle_parallel.yaml'


def test_a_namespaced_vehicle_takes_remapped_odometry_in_the_frames_it_is_given(nodes):
    """-r __ns, -r vehicle_1/odom:=/nav/odom, world_frame odom, base_frame robot_{id}/base."""
    frames = names.Frames('odom', 'robot_{id}/base')
    nodes.add(VehicleNode(1, context=nodes.context, cli_args=[
        '--ros-args', '-r', '__ns:=/fleet_a', '-r', 'vehicle_1/odom:=/nav/odom',
        '--params-file', str(PARTICLE), '-p', 'num_vehicles:=2', '-p', 'vehicle_id:=1',
        '-p', 'world_frame:=odom', '-p', 'base_frame:=robot_{id}/base']))
    node = nodes.node
    odom = node.create_publisher(Odometry, '/nav/odom', itf.STATE_QOS)
    peer = node.create_publisher(FormationState, '/fleet_a/vehicle_2/formation_state',
                                 itf.STATE_QOS)
    cmds = nodes.collect(VehicleCommand, '/fleet_a/vehicle_1/cmd', itf.STATE_QOS)
    assert nodes.spin_until(lambda: odom.get_subscription_count()
                            and peer.get_subscription_count())
    X = np.array([[0.5, -1.0], [1.0, 2.0], [0.3, 2.5], [0.2, -0.4], [1.0, 1.0], [0.0, 0.0]])
    wrong = itf.odom_msg(1, 0, X[:, 0], 0j)                          # map: not what was given
    odom.publish(wrong)
    assert nodes.spin_until(lambda: nodes.logged('fleet_a.vehicle_1',
                                                 "expected 'odom' -> 'robot_1/base'"))
    ns = 20_000_000
    peer.publish(itf.state_msg(2, ns, X[:, 1], (complex(-1, 2), 2.5, -0.4, 1.0),
                               frames=frames))
    odom.publish(itf.odom_msg(1, ns, X[:, 0], 0j, frames))
    assert nodes.spin_until(lambda: cmds)
    assert messages.stamp_ns(cmds[0].header.stamp) == ns
    assert cmds[0].header.frame_id == 'robot_1/base'


@pytest.mark.parametrize('param, message', [
    ('base_frame:=base_link', "'base_frame' = 'base_link' is invalid: must contain {id}"),
    ('world_frame:=/map', "'world_frame' = '/map' is invalid: a frame id"),
    ('world_frame:=vehicle_1/base_link', "'base_frame' = 'vehicle_{id}/base_link' is invalid: "
     'must differ from world_frame'),
])
def test_the_plant_refuses_frames_it_cannot_use(nodes, param, message):
    with pytest.raises(ScenarioError, match=message.replace('{', r'\{').replace('}', r'\}')):
        PlantNode(context=nodes.context,
                  cli_args=['--ros-args', '--params-file', str(PARTICLE), '-p', param])


def test_the_plant_refuses_gains_it_does_not_use(nodes):
    plant = nodes.plant(PARTICLE)
    result, = plant.set_parameters([Parameter('K', value=-2.0)])
    assert not result.successful and 'read-only' in result.reason
    assert 'formation-control set' in plant.describe_parameter('K').description


def test_fleet_set_arguments_are_checked_before_any_node_is_asked():
    k, c0, informed, nobody = tuning.parse(['K:=-2', 'c0:=[1, 2]', 'informed:=[1]',
                                            'informed:=[]'])
    assert (k.value, k.type_) == (-2.0, Parameter.Type.DOUBLE)
    assert (c0.value, informed.value) == ([1.0, 2.0], [1])
    assert (nobody.value, nobody.type_) == ([], Parameter.Type.INTEGER_ARRAY)
    with pytest.raises(ScenarioError, match="'informed' = '1' is invalid: a list of integers"):
        tuning.parse(['informed:=1'])
    with pytest.raises(ScenarioError, match="'num_vehicles' cannot change at run time"):
        tuning.parse(['num_vehicles:=3'])
    with pytest.raises(ScenarioError, match='give NAME:=VALUE'):
        tuning.parse(['kappa=3'])
    with pytest.raises(ScenarioError, match="'kappa' = '' is invalid: give a value"):
        tuning.parse(['kappa:='])


def _event(k, name, value):
    msg = ParameterEvent(node=f'/vehicle_{k}')
    value = Parameter(name, value=value).get_parameter_value()
    msg.changed_parameters = [ParameterMsg(name=name, value=value)]
    return msg


def test_the_monitor_follows_a_gain_once_every_vehicle_has_taken_it(nodes):
    """Seen from outside: its /diagnostics and its log, never its attributes."""
    sc = scenario.load(PARTICLE, ['num_vehicles:=3'])
    nodes.add(MonitorNode(context=nodes.context))
    node = nodes.node
    diagnostics = nodes.collect(DiagnosticArray, names.DIAGNOSTICS_TOPIC, itf.STREAM_QOS)
    node.create_publisher(String, names.SCENARIO_TOPIC, itf.LATCHED_QOS).publish(
        itf.scenario_msg(sc))
    events = node.create_publisher(ParameterEvent, '/parameter_events',
                                   qos_profile_parameter_events)

    def has_the_scenario():
        return any(s.name.endswith('formation') and 'waiting for' not in s.message
                   for d in diagnostics for s in d.status)
    assert nodes.spin_until(lambda: has_the_scenario() and events.get_subscription_count())

    def followed():
        return [m.msg for m in nodes.rosout if 'every vehicle took' in m.msg]
    for k in (1, 2):
        events.publish(_event(k, 'kappa', 2.5))
    events.publish(_event(3, 'kappa', 4.0))                     # the fleet disagrees
    for k in (1, 2):
        events.publish(_event(k, 'kappa', 4.0))                 # now it agrees
    assert nodes.spin_until(followed)
    assert followed() == ["every vehicle took {'kappa': 4.0}: the metrics follow"]


def test_a_swarm_in_a_namespace_with_its_own_frames_is_recorded_there(ros, tmp_path):
    """A swarm in a namespace: its topics, clock and bag are under /fleet_s."""
    from formation_control.bags import reader as bagfile
    from formation_control.sim import simulator
    from formation_control.swarm import run_swarm, SwarmOptions
    sc = scenario.load(PARTICLE, ['num_vehicles:=2'], duration=1.0)
    options = SwarmOptions(workdir=tmp_path / 'logs', env=ros.env,
                           node_params=('world_frame:=odom',))
    run, out = run_swarm(sc, options, namespace='fleet_s', bag=tmp_path / 'bag')
    np.testing.assert_allclose(run.X, simulator.simulate(sc).X, atol=1e-6)
    assert bagfile.fleet_prefix(tmp_path / 'bag') == '/fleet_s/'
    np.testing.assert_allclose(bagfile.read_run(tmp_path / 'bag').X[-1], run.X[-1], atol=1e-9)
    _, odom = next(bagfile.messages(tmp_path / 'bag', ['/fleet_s/vehicle_1/odom']))
    assert odom.header.frame_id == 'odom'
    assert len(bagfile.metrics(tmp_path / 'bag')[0]) > 0        # the monitor takes odom frames
    assert 'dropped' not in (tmp_path / 'logs' / 'monitor.log').read_text()


def test_an_integer_for_a_floating_point_gain_is_taken_as_ros_gives_it(nodes):
    """``-p kappa:=3`` at start and ``ros2 param set ... kappa 3`` (an INTEGER) at run time."""
    node = nodes.vehicle(1, CONFIG / 'particle_parallel.yaml', 'kappa:=3', 'flow:=[0, 0]')
    assert node.get_parameter('kappa').value == 3.0 and node.sc.kappa == 3.0
    result = node.set_parameters([Parameter('kappa', Parameter.Type.INTEGER, 4)])[0]
    assert result.successful, result.reason
    assert node.get_parameter('kappa').type_ == Parameter.Type.DOUBLE and node.sc.kappa == 4.0
    refused = node.set_parameters([Parameter('kappa', Parameter.Type.STRING, 'abc')])[0]
    assert not refused.successful and node.sc.kappa == 4.0


@pytest.mark.parametrize('args, says', [
    (['-p', 'kappa:=abc'], "error: parameter 'kappa' = 'abc' is invalid: a number"),
    (['-p', 'K_f:=[1]'], "error: parameter 'K_f' = [1] is invalid: a number"),
    (['--params-file', '/nonexistent.yaml'], "error: failed to initialize rcl: Couldn't parse "
     "params file: '--params-file /nonexistent.yaml'. Error: Error opening YAML file")])
def test_a_bad_command_line_exits_2_in_one_line(ros, args, says):
    """With the fleet's parameter file too: rcl would drop ``kappa:=abc`` in silence."""
    done = ros.procs.run('vehicle', '--ros-args', '--params-file',
                         CONFIG / 'particle_parallel.yaml', *args, '-p', 'vehicle_id:=1',
                         timeout=60)
    assert done.returncode == 2
    assert says in done.stderr and 'Traceback' not in done.stderr, done.stderr
