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
The formation table (core/formations.py): one object per ``formation``.

Each formation's default and allowed K, its law object, the radius of its steady motion, the
rate its laws act at, and the names its convergence is judged by, which sim/metrics defines.
"""
from formation_control.core import laws, parameters, scenario
from formation_control.core.control import Controller
from formation_control.core.errors import ScenarioError
from formation_control.core.formations import FORMATIONS, of
from formation_control.sim import metrics
import pytest


def test_the_table_holds_every_formation_with_its_default_gain():
    assert tuple(FORMATIONS) == parameters.FORMATIONS == ('parallel', 'circular')
    defaults = {name: f.default_K for name, f in FORMATIONS.items()}
    assert defaults == {'parallel': -1.0, 'circular': 1.0}
    for name, f in FORMATIONS.items():
        assert scenario.resolve({'formation': name}).K == f.default_K


@pytest.mark.parametrize('params, match', [
    ({'formation': 'parallel', 'K': 0.5}, r"'K' = 0.5 .*parallel needs K < 0"),
    ({'formation': 'circular', 'K': -0.5}, r"'K' = -0.5 .*circular needs K > 0"),
    ({'formation': 'circular', 'omega0': 0.0}, r"'omega0' = 0.0 .*omega0 != 0"),
])
def test_each_formation_refuses_the_gains_its_law_does_not_converge_with(params, match):
    with pytest.raises(ScenarioError, match=match):
        scenario.resolve(params)


def test_the_law_object_and_the_steady_motion_of_each_formation():
    parallel = scenario.resolve({'formation': 'parallel', 'K': -0.3})
    circular = scenario.resolve({'formation': 'circular', 'K': 0.2, 'omega0': -0.25,
                                 'c0': [1.0, 2.0], 'informed': [1]})
    f = Controller(parallel).formation
    assert isinstance(f, laws.Parallel) and f.K == -0.3
    assert of(parallel).radius(parallel) is None
    assert of(parallel).law_rate(parallel, 0.5)[0] == 0.3
    c = Controller(circular).formation
    assert isinstance(c, laws.Circular) and (c.K, c.omega0, c.c0) == (0.2, -0.25, 1 + 2j)
    assert of(circular).radius(circular) == 4.0
    assert of(circular).law_rate(circular, 0.5)[0] == 0.125


def test_the_errors_and_conditions_each_formation_names_are_defined():
    for f in FORMATIONS.values():
        assert set(f.band_errors) <= set(metrics.ERRORS) and set(f.band_errors) <= set(
            metrics.BANDS)
        assert set(f.conditions) <= set(metrics.CONDITIONS)
