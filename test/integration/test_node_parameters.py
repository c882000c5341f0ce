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

"""Every parameter a node declares is in one table, with the descriptor the table gives."""
from formation_control.core import parameters
from formation_control.protocol import node_parameters
import pytest
from rclpy.parameter import Parameter
from runs import CONFIG

ROS_OWN = ('use_sim_time', 'start_type_description_service')
"""Parameters rclpy declares on every node."""
TABLES = {'plant': node_parameters.PLANT, 'vehicle_2': node_parameters.VEHICLE,
          'formation_monitor': node_parameters.MONITOR}


def _own(node):
    return {name for name in node._parameters if name not in parameters.PARAMETERS
            and name not in ROS_OWN and not name.startswith('qos_overrides.')}


@pytest.mark.parametrize('make', ['plant', 'vehicle', 'monitor'])
def test_node_parameters_are_the_table_and_read_only(nodes, make):
    path = CONFIG / 'rigid_circular.yaml'
    node = {'plant': lambda: nodes.plant(path), 'vehicle': lambda: nodes.vehicle(2, path),
            'monitor': lambda: nodes.monitor()}[make]()
    table = TABLES[node.get_name()]
    declared = _own(node)
    assert declared <= set(table), declared - set(table)
    if make != 'vehicle':                 # vehicle_ids belongs to the vehicles executable
        assert declared == set(table)
    for name in declared:
        default, spec = table[name]
        d = node.describe_parameter(name)
        assert d.read_only == (not spec.runtime) and spec.text in d.description, name
        if spec.low is not None:
            r = (d.floating_point_range or d.integer_range)[0]
            assert (r.from_value, r.to_value) == (spec.low, spec.high), name
        if name != 'vehicle_id':
            value = node.get_parameter(name).value
            assert value == (list(default) if isinstance(default, tuple) else default), name
    unset = [name for name, p in node._parameters.items() if p.type_ == Parameter.Type.NOT_SET]
    assert not unset, f'declared without a value (ros2 param dump answers nothing): {unset}'
    runtime = [name for name in parameters.RUNTIME
               if node.has_parameter(name) and not node.describe_parameter(name).read_only]
    assert runtime == (list(parameters.RUNTIME) if make == 'vehicle' else [])   # plant: read-only
