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

"""Liveness, injected faults and the law over a live subset of the fleet (no ROS)."""
from formation_control.core import scenario
from formation_control.core.control import Controller
from formation_control.core.errors import ScenarioError
from formation_control.protocol import links
import numpy as np
import pytest
from runs import CONFIG


def test_liveness_waits_for_the_unheard_and_drops_the_silent():
    live = links.Liveness(3, timeout=1.0)
    live.heard(0, 10.0)
    live.heard(1, 10.5)
    assert list(live.gone(11.2)) == [True, False, False]      # 2 never heard: waited for
    assert list(live.alive(11.2)) == [False, True, False]
    assert live.gone(11.2, since=11.0)[0]                       # still gone: not heard since
    live.heard(0, 11.3)
    assert live.alive(11.4)[0]


def test_lockstep_silence_counts_from_the_start_of_the_step():
    """A peer that answered step n and waits for step n + 1 is not gone, however long n lasts."""
    live = links.Liveness(2, timeout=1.0)
    live.heard(0, 10.0)
    assert not live.gone(15.0, since=14.5)[0]
    assert live.gone(15.6, since=14.5)[0]
    assert live.gone(15.7, since=15.65)[0]                 # gone until heard again
    live.heard(0, 15.8)
    assert not live.gone(15.9, since=15.85)[0]
    assert not live.gone(25.0, since=15.85, answered=[True, False])[0]


def test_faults_are_seeded_and_match_their_rates():
    def draws(seed):
        f = links.Faults(drop_probability=0.2, delay=0.05, delay_jitter=0.1, fault_seed=seed,
                         vehicle_id=3)
        return [f.admit(2) for _ in range(20_000)]
    a, b = draws(7), draws(7)
    assert a == b and a != draws(8)
    dropped = sum(d is None for d in a) / len(a)
    delays = np.array([d for d in a if d is not None])
    assert dropped == pytest.approx(0.2, abs=0.01)
    assert delays.min() >= 0.05 and delays.max() <= 0.15
    assert delays.mean() == pytest.approx(0.1, abs=0.002)


def test_faults_apply_to_the_listed_links_and_range_only():
    f = links.Faults(drop_probability=1.0, comm_range=2.0, fault_links=(2,), vehicle_id=1)
    assert f.admit(2) is None and f.admit(3) == 0.0
    assert f.out_of_range(2, 0j, 2.5 + 0j) and not f.out_of_range(2, 0j, 1.5j)
    assert not f.out_of_range(3, 0j, 10 + 0j)


@pytest.mark.parametrize('values, message', [
    ({'drop_probability': 1.5}, r"'drop_probability' = 1.5 is invalid: allowed range \[0, 1\]"),
    ({'delay': -0.1}, r"'delay' = -0.1 is invalid: allowed range \[0, 10\]"),
    ({'fault_links': (1, 4)}, r"'fault_links' = \[1, 4\] is invalid: neighbour ids in 1..3 other "
                              r'than 1'),
])
def test_bad_link_parameters_name_the_parameter_and_range(values, message):
    with pytest.raises(ScenarioError, match=message):
        links.check(values, 3, 1)


@pytest.mark.parametrize('name', ['rigid_circular_center', 'particle_circular',
                                  'particle_parallel'])
def test_law_over_a_live_subset_equals_the_law_of_the_smaller_fleet(name):
    """Vehicle k hearing only the members equals vehicle k of a fleet made of the members."""
    sc = scenario.load(CONFIG / f'{name}.yaml', ['num_vehicles:=5'])
    members = np.array([True, False, True, True, False])
    X = scenario.initial_state(sc)
    ctrl = Controller(sc)
    view = ctrl.view(X)
    sub = ctrl.view(X[:, members])
    own = 1                                      # vehicle 3 is the second member
    U = ctrl.command(sub, X[:, [2]], [own], members=members)
    informed = [k for k in range(1, 6) if members[k - 1] and k in sc.informed]
    small = scenario.resolve({**sc.to_dict(), 'num_vehicles': 3, 'init_x': [], 'init_y': [],
                              'init_theta': [], 'init_omega': [], 'init_u': [], 'init_v': [],
                              'informed': [[1, 3, 4].index(k) + 1 for k in informed]})
    expected = Controller(small).command(sub, X[:, [2]], [own])
    np.testing.assert_allclose(U, expected, rtol=0, atol=1e-12)
    assert not np.allclose(U, ctrl.command(view, X[:, [2]], [2]))
