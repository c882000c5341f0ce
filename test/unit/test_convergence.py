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
Every particle scenario of config/ converges from several random seeds to what Ch. 1-5 predict.

Parallel: |p| > 0.999 with zero turning rates; circular: coincident centres on radius 1/|omega0|
(turning at omega0 s_k with inertial speed s_k in a flow). The flow scenarios converge the same
with vehicles that estimate the flow (``flow_source: estimated``, seed 1).
"""
import numpy as np
import pytest

from runs import run_of, SEEDS, SOURCES, views

PARALLEL = ['particle_parallel', 'particle_parallel_flow', 'particle_parallel_proportional',
            'first_order_parallel']
CIRCULAR = ['particle_circular', 'particle_circular_flow', 'first_order_circular']


def _cases(names):
    """(name, seed, source): every seed told the flow, seed 1 estimating it in a flow."""
    return [(n, s, 'known') for n in names for s in SEEDS] + [
        (n, 1, 'estimated') for n in names if n.endswith('_flow')]


@pytest.mark.slow
@pytest.mark.parametrize('name, seed, source', _cases(PARALLEL))
def test_parallel_scenarios_synchronise(name, seed, source):
    run = run_of(name, seed, SOURCES[source])
    _, vs = views(run)
    final = vs[-1]
    assert abs(final.e.mean()) > 0.999
    assert np.max(abs(final.rate)) < 1e-3
    assert np.max(abs(run.X[-1, 3])) < 1e-3                  # body turning rate too
    assert abs(vs[0].e.mean()) < 0.9                          # it did have work to do


@pytest.mark.slow
@pytest.mark.parametrize('name, seed, source', _cases(CIRCULAR))
def test_circular_scenarios_share_one_circle(name, seed, source):
    run = run_of(name, seed, SOURCES[source])
    ctrl, vs = views(run)
    sc, final = run.sc, vs[-1]
    c = ctrl.formation.centres(final)
    assert np.max(abs(c - c.mean())) < 1e-2
    np.testing.assert_allclose(abs(final.r - c.mean()), 1 / abs(sc.omega0), rtol=1e-2)
    np.testing.assert_allclose(final.rate, sc.omega0 * final.speed, atol=1e-2)
    c0 = ctrl.formation.centres(vs[0])
    assert np.max(abs(c0 - c0.mean())) > 1.0


@pytest.mark.slow
@pytest.mark.parametrize('seed, source', [(s, 'known') for s in SEEDS] + [(1, 'estimated')])
def test_circular_in_flow_moves_at_the_inertial_speed(seed, source):
    """(1.6): on the common circle the inertial speed varies with gamma, s = |e^{i theta} + f|."""
    run = run_of('particle_circular_flow', seed, SOURCES[source])
    _, vs = views(run)
    final = vs[-1]
    alpha = run.sc.flow[0]
    s_of_gamma = alpha * np.cos(final.phase) + np.sqrt(1 - (alpha * np.sin(final.phase)) ** 2)
    np.testing.assert_allclose(final.speed, s_of_gamma, rtol=1e-9)
    assert np.ptp(final.speed) > 0.5                           # spread round the circle


@pytest.mark.slow
def test_backstepping_matches_first_order_speed_of_convergence():
    """Ch. 9: the second-order laws perform comparably to the first-order ones."""
    from formation_control.sim.simulator import summary
    first = summary(run_of('first_order_circular', 1))['convergence_time']
    second = summary(run_of('particle_circular', 1))['convergence_time']
    assert 0.5 < second / first < 2.0
