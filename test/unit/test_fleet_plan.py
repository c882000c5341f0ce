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

"""The fleet described once: its processes and their parameters (swarm and launch files)."""
from formation_control.core.errors import ScenarioError
from formation_control.core.scenario import load
from formation_control.protocol import fleet_plan
from formation_control.protocol.fleet_plan import (auto_per_process, FleetPlan, LAUNCH_LABELS,
                                                   ros_arguments, SWARM_LABELS)
from formation_control.protocol.onboard import vehicle_topics
import pytest
from runs import CONFIG


def test_one_vehicle_process_each_by_default():
    plan = FleetPlan(3)
    processes = [plan.plant(), *plan.vehicles(), plan.monitor()]
    assert [(p.name, p.executable, p.vehicles) for p in processes] == [
        ('plant', 'plant', ()), ('vehicle_1', 'vehicle', (1,)), ('vehicle_2', 'vehicle', (2,)),
        ('vehicle_3', 'vehicle', (3,)), ('monitor', 'monitor', ())]
    assert [p.parameters for p in plan.vehicles()] == [{'vehicle_id': k} for k in (1, 2, 3)]
    assert [p.member for p in processes] == [p.name for p in processes]


def test_vehicles_are_split_into_processes_of_per_process_the_last_one_shorter():
    plan = FleetPlan(6, per_process=4)
    assert [(p.name, p.executable, p.vehicles, p.parameters) for p in plan.vehicles()] == [
        ('vehicles_1-4', 'vehicles', (1, 2, 3, 4), {'vehicle_ids': [1, 2, 3, 4]}),
        ('vehicles_5-6', 'vehicles', (5, 6), {'vehicle_ids': [5, 6]})]
    assert FleetPlan(2, per_process='5').groups() == [(1, 2)]           # a launch argument


def test_the_plant_and_vehicles_take_the_fleet_file_the_monitor_and_recorder_the_clock():
    frames = {'world_frame': 'odom', 'base_frame': 'b{id}'}
    plan = FleetPlan(2, 'lockstep', namespace='fleet_a', recorded=True, frames=frames)
    assert plan.common == {'mode': 'lockstep', **frames}
    assert plan.clock == ('/clock', '/fleet_a/clock')
    plant = plan.plant(record_path='run.npz')
    assert plant.fleet and not plant.clock
    assert plant.parameters == {'record_path': 'run.npz', 'wait_for_start': True}
    monitor = plan.monitor(foxglove_port=8765)
    assert not monitor.fleet and monitor.clock
    assert monitor.parameters == {'world_frame': 'odom', 'base_frame': 'b{id}',
                                  'foxglove_port': 8765, 'use_sim_time': True}
    recorder = plan.recorder('bag', monitor=False, vehicle_topics=('odom', 'cmd'))
    assert (recorder.member, recorder.fleet, recorder.clock) == ('swarm', False, True)
    assert recorder.parameters == {'bag': 'bag', 'num_vehicles': 2, 'monitor': False,
                                   'vehicle_topics': ['odom', 'cmd'], 'use_sim_time': True}


def test_in_real_time_nothing_takes_the_fleet_time_and_the_plant_does_not_wait():
    plan = FleetPlan(1, 'realtime')
    assert plan.common == {'mode': 'realtime'} and plan.clock == ('/clock', '/clock')
    assert plan.monitor().parameters == {'use_sim_time': False}
    assert plan.plant().parameters == {'wait_for_start': False}


@pytest.mark.parametrize('value', [0, -1, '0', 'two', '', 1.0, True])
def test_vehicles_per_process_must_be_an_integer_from_1(value):
    with pytest.raises(ScenarioError, match=rf'^--vehicles-per-process {value!r} is invalid: '
                                            r"an integer >= 1 or 'auto'$"):
        FleetPlan(3, per_process=value)
    with pytest.raises(ScenarioError, match=rf'^vehicles_per_process {value!r} is invalid'):
        FleetPlan(3, per_process=value, labels=LAUNCH_LABELS)


def test_a_secure_fleet_runs_one_vehicle_per_process():
    assert FleetPlan(3, per_process=1, secure=True).per_process == 1
    with pytest.raises(ScenarioError, match='^--vehicles-per-process 2 with --secure: a member '
                                            'of a TLS fleet is one process, 1 only$'):
        FleetPlan(3, per_process=2, secure=True, labels=SWARM_LABELS)
    with pytest.raises(ScenarioError, match='^vehicles_per_process 2 with secure:'):
        FleetPlan(3, per_process='2', secure=True, labels=LAUNCH_LABELS)


@pytest.mark.parametrize('n, cores, per_process', [
    (16, 2, 8), (17, 2, 9), (4, 2, 2), (5, 2, 3), (16, 1, 16), (16, 8, 2), (1, 2, 1), (64, 2, 32)])
def test_auto_spreads_the_fleet_over_one_process_per_core(n, cores, per_process):
    assert auto_per_process(n, cores) == per_process
    assert auto_per_process(n, cores, one_each=True) == 1


def test_auto_runs_one_vehicle_per_process_in_a_secure_fleet_or_with_process_faults(monkeypatch):
    monkeypatch.setattr(fleet_plan, 'cores', lambda: 2)
    assert FleetPlan(16, per_process='auto').per_process == 8
    assert FleetPlan(16, per_process='auto', secure=True).per_process == 1
    assert FleetPlan(16, per_process='auto', process_faults=True).per_process == 1
    with pytest.raises(ScenarioError, match=r'^--vehicles-per-process 4 with a process fault '
                                            r'\(kill, restart, stop, cont\): a fault acts on the '
                                            r'process of one vehicle, 1 only$'):
        FleetPlan(16, per_process=4, process_faults=True)


def test_parameters_as_ros_arguments():
    assert ros_arguments({'use_sim_time': False, 'vehicle_ids': [1, 2], 'real_time_factor': 2.0,
                          'mode': 'lockstep'}) == [
        '-p', 'use_sim_time:=false', '-p', 'vehicle_ids:=[1, 2]', '-p', 'real_time_factor:=2.0',
        '-p', 'mode:=lockstep']


LOCALHOST = {'ROS_AUTOMATIC_DISCOVERY_RANGE': 'LOCALHOST'}


def test_more_participants_than_localhost_discovery_reaches_are_refused_with_the_grouping():
    fleet_plan.check_discovery(32, 30, 1, '--vehicles-per-process', LOCALHOST)
    with pytest.raises(ScenarioError) as refused:     # 32 vehicles, plant, monitor, swarm
        fleet_plan.check_discovery(35, 32, 1, '--vehicles-per-process', LOCALHOST)
    message = str(refused.value)
    assert message.startswith('--vehicles-per-process 1 makes 35 DDS participants')
    assert 'at most 32' in message and 'use --vehicles-per-process 2 or more' in message
    groups = -(-32 // 2)                                # two each fit: 16 + 3 participants
    fleet_plan.check_discovery(groups + 3, 32, 2, '--vehicles-per-process', LOCALHOST)


@pytest.mark.parametrize('environ', [{}, {'ROS_AUTOMATIC_DISCOVERY_RANGE': 'SUBNET'},
                                     {**LOCALHOST, 'ROS_DISCOVERY_SERVER': '127.0.0.1:11811'},
                                     {**LOCALHOST, 'RMW_IMPLEMENTATION': 'rmw_cyclonedds_cpp'}])
def test_the_limit_is_localhost_discovery_of_rmw_fastrtps_only(environ):
    fleet_plan.check_discovery(65, 64, 1, '--vehicles-per-process', environ)


@pytest.mark.parametrize('overrides, topics', [
    ((), ('odom', 'flow', 'formation_state', 'cmd')),
    (('flow_source:=estimated',), ('odom', 'water_velocity', 'formation_state', 'cmd')),
    (('model:=second_order', 'flow_source:=estimated'), ('odom', 'formation_state', 'cmd')),
    (('flow_model:=vortex', 'flow_circulation:=2.0'), ('odom', 'flow', 'formation_state',
                                                       'cmd')),
])
def test_each_vehicle_publishes_the_topics_its_scenario_needs(overrides, topics):
    sc = load(CONFIG / 'rigid_circular_flow.yaml', list(overrides))
    assert vehicle_topics(sc) == topics
    aircraft = load(CONFIG / 'aircraft_circular.yaml', [])
    assert vehicle_topics(aircraft) == ('odom', 'flow', 'formation_state', 'cmd', 'cmd_vel')
