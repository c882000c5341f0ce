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

"""swarm.Swarm: the commands and environments of a fleet's processes, from its plan and options."""
from formation_control.core.scenario import resolve
from formation_control.protocol.fleet_plan import FleetPlan
from formation_control.swarm import Swarm, SwarmOptions
import pytest


def _after(command, flag):
    """Return the values that follow each ``flag`` in ``command``."""
    return [command[i + 1] for i, a in enumerate(command) if a == flag]


def test_a_swarm_runs_the_processes_of_its_plan_in_its_namespace(tmp_path):
    sc = resolve({'num_vehicles': 4})
    plan = FleetPlan(4, 'realtime', per_process=2, namespace='fleet_a/', recorded=True)
    options = SwarmOptions(real_time_factor=2.0, workdir=tmp_path, place=lambda name: ['on', name],
                           node_params=('world_frame:=odom', 'delay:=0.1'),
                           monitor_params=('foxglove_port:=8765',), env={'ROS_DOMAIN_ID': '7'})
    swarm = Swarm(sc, plan, options)
    assert swarm.names == ['plant', 'vehicles_1-2', 'vehicles_3-4', 'monitor']
    assert swarm.members == [(), (1, 2), (3, 4), ()] and swarm.process_of[3] == 2
    assert swarm.mode == 'realtime' and swarm.prefix == '/fleet_a/'
    assert swarm.dir == tmp_path and (tmp_path / 'scenario.yaml').is_file()
    plant, vehicles, _, monitor = swarm.commands
    for command in swarm.commands:
        assert _after(command, '-r')[0] == '__ns:=/fleet_a'
    assert 'real_time_factor:=2.0' in _after(plant, '-p')
    assert 'wait_for_start:=true' in _after(plant, '-p')
    assert {'world_frame:=odom', 'delay:=0.1', 'vehicle_ids:=[1, 2]'} <= set(
        _after(vehicles, '-p'))
    assert 'foxglove_port:=8765' in _after(monitor, '-p')
    assert 'world_frame:=odom' in _after(monitor, '-p')
    assert 'foxglove_port:=8765' not in _after(plant, '-p')
    assert swarm.place('plant') == ['on', 'plant']
    env = swarm.envs['vehicles_1-2']
    assert env['ROS_DOMAIN_ID'] == '7' and env['FASTRTPS_DEFAULT_PROFILES_FILE'].startswith(
        str(tmp_path))


def test_a_swarm_without_a_monitor_or_namespace(tmp_path):
    swarm = Swarm(resolve({'num_vehicles': 2}), FleetPlan(2),
                  SwarmOptions(workdir=tmp_path, monitor=False, restart_dead=0.5,
                               place=lambda name: []))
    assert swarm.names == ['plant', 'vehicle_1', 'vehicle_2']
    assert all(not _after(command, '-r') or '__ns' not in _after(command, '-r')[0]
               for command in swarm.commands)
    assert swarm.restart_dead == 0.5 and swarm.mode == 'lockstep'


def test_the_options_are_a_frozen_record():
    options = SwarmOptions()
    assert options.monitor and options.real_time_factor == 1.0 and options.secure is None
    with pytest.raises(AttributeError):
        options.monitor = False
