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
The .msg files of formation_control_msgs, read as rosidl reads them (no build needed).

They must carry what the fleet's code names (every metric of METRIC_DOC, every fault kind, a
command kind per particle model), one interface version, a comment on every field, and be
listed in CMakeLists.txt (a .msg file not listed there is not built).
"""
from pathlib import Path
import re
import sys

from formation_control.core.vehicles import VEHICLE_MODELS
from formation_control.protocol import cdr, faults, messages
from formation_control.protocol.messages import METRIC_DOC
import pytest
from rosidl_adapter.parser import parse_message_file

PACKAGE = Path(__file__).resolve().parents[2] / 'formation_control_msgs'
NAMES = ('FaultEvent', 'FormationMetrics', 'FormationState', 'VehicleCommand')


def spec(name):
    return parse_message_file(PACKAGE.name, str(PACKAGE / 'msg' / f'{name}.msg'))


def fields(name):
    return {f.name: f for f in spec(name).fields}


def constants(name):
    return {c.name: c.value for c in spec(name).constants}


def test_cmakelists_builds_every_msg_file():
    listed = re.findall(r'msg/(\w+)\.msg', (PACKAGE / 'CMakeLists.txt').read_text())
    assert sorted(listed) == sorted(p.stem for p in (PACKAGE / 'msg').glob('*.msg'))
    assert sorted(listed) == list(NAMES)


@pytest.mark.parametrize('name', NAMES)
def test_every_field_and_constant_is_commented(name):
    s = spec(name)
    bare = [f.name for f in s.fields if not ''.join(f.annotations.get('comment', []))]
    bare += [c.name for c in s.constants if not ''.join(c.annotations.get('comment', []))
             and c.name != 'INTERFACE_VERSION']
    assert bare == []


@pytest.mark.parametrize('name', NAMES)
def test_one_interface_version_that_every_message_sends_by_default(name):
    version = constants('FormationState')['INTERFACE_VERSION']
    assert constants(name)['INTERFACE_VERSION'] == version
    field = fields(name)['interface_version']
    assert (str(field.type), field.default_value) == ('uint8', version)


def test_metrics_carry_every_metric_the_monitor_names():
    metrics = fields('FormationMetrics')
    assert set(METRIC_DOC) - set(metrics) == set()
    assert {str(metrics[name].type) for name in METRIC_DOC} <= {'float64', 'uint32'}
    assert str(metrics['converged'].type) == 'bool'
    assert str(metrics['convergence_time'].type) == 'float64'


def test_state_names_whom_it_hears_and_its_flow_estimate():
    state = fields('FormationState')
    for name in ('x', 'y', 'heading', 'yaw_rate', 'phase', 'phase_rate', 'speed', 'flow_hat_x',
                 'flow_hat_y'):
        assert str(state[name].type) == 'float64', name
    assert str(state['neighbour_ids'].type) == 'uint32[]'
    assert str(state['hears'].type) == 'bool[]'
    assert str(state['estimates_flow'].type) == 'bool'
    assert str(state['predicted_stamp'].type) == 'builtin_interfaces/Time'


def test_fault_kinds_are_those_of_the_fault_script():
    kinds = {name: value for name, value in constants('FaultEvent').items()
             if name != 'INTERFACE_VERSION'}
    assert set(kinds) == {kind.upper() for kind in faults.PROCESS_KINDS + faults.LINK_KINDS}
    assert 0 not in kinds.values() and len(set(kinds.values())) == len(kinds)


def test_a_command_kind_per_particle_model_and_one_for_rigid_bodies():
    kinds = {name: value for name, value in constants('VehicleCommand').items()
             if name != 'INTERFACE_VERSION'}
    assert set(kinds) == {m.name.upper() for m in VEHICLE_MODELS.values() if m.particle} | {
        'RIGID_BODY'}
    assert 0 not in kinds.values() and len(set(kinds.values())) == len(kinds)
    assert {'thrust', 'steering_force', 'angular_acceleration', 'turn_rate'} <= set(
        fields('VehicleCommand'))


def _definition(parsed, nested):
    """Return a parsed .msg's fields as (name, type) pairs, nested types expanded."""
    out = []
    for f in parsed.fields:
        kind = f'{f.type.pkg_name}/{f.type.type}' if f.type.pkg_name else str(f.type)
        out.append((f.name, _definition(nested[kind], nested) if kind in nested else kind))
    return tuple(out)


SHARE = Path(sys.prefix) / 'share'


@pytest.mark.skipif(not (SHARE / 'std_msgs' / 'msg' / 'Header.msg').is_file(),
                    reason='std_msgs is not installed in this environment')
@pytest.mark.parametrize('name, definition', [('FormationState', messages.FORMATION_STATE),
                                              ('VehicleCommand', messages.VEHICLE_COMMAND)])
def test_the_wire_layouts_are_the_msg_definitions(name, definition):
    """The canonical bytes' field lists, nested Header and Time included, are the .msg files'."""
    nested = {f'{pkg}/{msg}': parse_message_file(pkg, str(SHARE / pkg / 'msg' / f'{msg}.msg'))
              for pkg, msg in (('std_msgs', 'Header'), ('builtin_interfaces', 'Time'))}
    assert _definition(spec(name), nested) == definition
    assert (definition[0], constants(name)['INTERFACE_VERSION']) == (
        ('interface_version', 'uint8'), messages.INTERFACE_VERSION)
    assert _definition(nested['std_msgs/Header'], nested) == cdr.HEADER


def test_the_command_kinds_are_the_msg_constants():
    kinds = constants('VehicleCommand')
    assert {m: messages.command_kind(m) for m in ('rigid', 'second_order', 'first_order')} == {
        'rigid': kinds['RIGID_BODY'], 'second_order': kinds['SECOND_ORDER'],
        'first_order': kinds['FIRST_ORDER']}
