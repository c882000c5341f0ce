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
The parameter table (core/parameters.py) is a leaf, and names what the features implement.

It imports no physics module but the vehicle-model registry, which imports nothing of the
scenario (type-only imports included); the values its choices allow are
exactly the names of the vehicle models, formations and steering laws the features implement;
:func:`scenario.resolve` runs the table's check first, then every feature's.
"""
import importlib
import pkgutil

from formation_control import core
from formation_control.core import formations, models, parameters, scenario, steering
from formation_control.core.vehicles import VEHICLE_MODELS
from test_layers import graph


def test_the_table_imports_no_physics_module():
    edges, _ = graph()
    inside = {m.removeprefix('formation_control.core.')
              for m in edges['formation_control.core.parameters']}
    assert inside <= {'errors', 'geometry', 'graphs', 'vehicles', 'vehicles.base'}
    for below in ('graphs', 'vehicles', 'vehicles.base'):
        assert 'formation_control.core.parameters' not in edges[f'formation_control.core.{below}']


def test_the_choices_are_what_the_features_implement():
    assert parameters.CHOICES['model'] == tuple(VEHICLE_MODELS)
    assert parameters.STATE_NAMES == models.STATE_NAMES
    assert parameters.FORMATIONS == tuple(formations.FORMATIONS)
    assert parameters.CONTROLLERS == tuple(steering.LAWS)


def test_the_documented_default_of_K_is_each_formations():
    shown = ', '.join(f'{f.default_K} {name}' for name, f in formations.FORMATIONS.items())
    assert parameters.PARAMETERS['K'].shown_default == shown


def test_resolve_runs_the_check_of_every_feature_that_has_one():
    names = (m.name for m in pkgutil.iter_modules(core.__path__))
    found = {name for name in names if callable(getattr(
        importlib.import_module(f'formation_control.core.{name}'), 'check', None))}
    assert found == {c.__module__.rsplit('.', 1)[-1] for c in scenario.CHECKS}
    assert scenario.CHECKS[0] is parameters.check
