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

"""protocol/names.py normalises every spelling of a namespace the same way."""
from formation_control.protocol import names
import pytest

ROOT = ('', '/', '//')
FLEET = ('fleet_a', '/fleet_a', 'fleet_a/', '/fleet_a/', '//fleet_a//')


EXPECTED = [(ns, ('/', '/', '', '/formation/scenario')) for ns in ROOT] + \
    [(ns, ('/fleet_a/', '/fleet_a', 'fleet_a/', '/fleet_a/formation/scenario')) for ns in FLEET]


@pytest.mark.parametrize('namespace, expected', EXPECTED)
def test_root_and_fleet_namespaces(namespace, expected):
    assert (names.namespace_prefix(namespace), names.namespace_of(namespace),
            names.status_prefix(namespace), names.resolve(namespace, 'formation/scenario')) \
        == expected
    if namespace in FLEET:
        assert names.resolve(namespace, 'vehicle_1/odom') == '/fleet_a/vehicle_1/odom'


@pytest.mark.parametrize('namespace', ('/fleet_a/team_2', 'fleet_a/team_2/'))
def test_nested_namespace(namespace):
    assert names.namespace_prefix(namespace) == '/fleet_a/team_2/'
    assert names.namespace_of(namespace) == '/fleet_a/team_2'
    assert names.status_prefix(namespace) == 'fleet_a/team_2/'


@pytest.mark.parametrize('namespace', ROOT + FLEET)
def test_absolute_names_are_kept(namespace):
    assert names.resolve(namespace, names.DIAGNOSTICS_TOPIC) == '/diagnostics'
    assert names.resolve(namespace, '/clock') == '/clock'
